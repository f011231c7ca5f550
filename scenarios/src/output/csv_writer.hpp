#pragma once
// The trajectory CSV of `nonholo run --out FILE.csv` (or - for standard output): t, q and the
// diagnostics per frame, with shortest round-trip formatting, so that no digit of the state is
// lost. A row is formatted into a fixed buffer and written whenever that fills (a row of a
// million-body chain has three million numbers: no buffer of its size).
#include <nonholo/diagnostics.hpp>
#include <nonholo/types.hpp>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <string>
#include <vector>

namespace nonholo::scenarios {

class CsvWriter {
 public:
  // Creates the file (path "-": standard output) and writes the header; throws
  // std::invalid_argument when it cannot be opened.
  CsvWriter(const std::string& path, const std::vector<std::string>& coordinates);
  // Continues the CSV of a run resumed from a checkpoint that had written `bytes` bytes of it,
  // whose last ones hashed to `tail` (tail_hash): what follows them (rows written after the
  // checkpoint) is dropped. Throws std::invalid_argument, the file left as it is, when it is
  // shorter or those bytes differ (another run or program has rewritten it since).
  CsvWriter(const std::string& path, long bytes, std::uint64_t tail);
  ~CsvWriter();
  CsvWriter(const CsvWriter&) = delete;
  CsvWriter& operator=(const CsvWriter&) = delete;
  // Writes what is buffered to the file and flushes it (a checkpoint's moment): the bytes so far.
  long flush_to_disk();
  // After flush_to_disk: the hash of the file's last bytes so far (up to kTail of them; 0 for
  // standard output), what the checkpoint records of it. Reads them back: what a resume will see.
  std::uint64_t tail_hash() const;
  void row(double t, ConstVecRef q, const Diagnostics& d);
  // Flushes and reports a write error (disk full, ...) as an exception.
  void close();

 private:
  // A double takes at most 24 characters with to_chars; 32 leaves room for the comma.
  static constexpr std::size_t kField = 32, kBuffer = 1 << 16;
  static constexpr long kTail = 1 << 16;  // the bytes a checkpoint knows its output by: a row or more
  void write(const char* data, std::size_t size);
  void put(char*& p, double v);
  std::string path_;
  bool stdout_ = false;  // --out -
  long written_ = 0;  // bytes handed to the file
  std::FILE* file_ = nullptr;
  char buffer_[kBuffer];
};

}  // namespace nonholo::scenarios
