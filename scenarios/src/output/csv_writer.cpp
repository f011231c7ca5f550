// The trajectory CSV of `nonholo run --out FILE.csv` (csv_writer.hpp): its header, rows,
// continuation after a checkpoint and the flushes that keep a killed run's rows on disk.
#include "output/csv_writer.hpp"

#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <charconv>
#include <cstring>
#include <functional>
#include <string>
#include <stdexcept>

namespace nonholo::scenarios {

CsvWriter::CsvWriter(const std::string& path, const std::vector<std::string>& coordinates)
    : path_(path == "-" ? "standard output" : path), stdout_(path == "-") {
  file_ = stdout_ ? stdout : std::fopen(path.c_str(), "w+");  // read too: tail_hash reads back
  if (!file_)
    throw std::invalid_argument("cannot open '" + path + "' for writing: " + std::strerror(errno));
  std::string header = "t";
  for (const auto& c : coordinates) {
    if (header.size() > kBuffer) {  // in pieces, as the rows
      write(header.data(), header.size());
      header.clear();
    }
    header.append(1, ',').append(c);
  }
  header += ",energy,energy_post,residual\n";
  write(header.data(), header.size());
}

namespace {
// A hash of the `count` bytes of a file before `end`, read with pread (the FILE's position
// stays); false when they cannot be read. std::hash: the same within a build, and a checkpoint
// is only resumed by the build that wrote it.
bool hash_bytes(int fd, long end, long count, std::uint64_t& hash) {
  std::string bytes(static_cast<std::size_t>(count), '\0');
  for (long done = 0; done < count;) {
    const ssize_t got = ::pread(fd, bytes.data() + done, static_cast<std::size_t>(count - done), end - count + done);
    if (got <= 0) return false;
    done += got;
  }
  hash = std::hash<std::string>{}(bytes);
  return true;
}
}  // namespace

CsvWriter::CsvWriter(const std::string& path, long bytes, std::uint64_t tail) : path_(path), written_(bytes) {
  file_ = std::fopen(path.c_str(), "r+b");
  if (!file_)
    throw std::invalid_argument("cannot continue '" + path + "': cannot open it for writing: " + std::strerror(errno));
  std::fseek(file_, 0, SEEK_END);
  const long size = std::ftell(file_);
  const auto foreign = [&](const std::string& what) {
    return std::invalid_argument("cannot continue '" + path + "': " + what +
                                 ": not the output of this run (another run or program has written it since the "
                                 "checkpoint); it is left as it is: give the run's file back, or start the run afresh");
  };
  if (size < bytes)
    throw foreign("it holds " + std::to_string(size) + " bytes where the checkpoint wrote " + std::to_string(bytes));
  // The rows up to the checkpoint must be the ones it wrote (the length alone let another run's
  // file be cut and appended to): checked before anything is cut.
  std::uint64_t found = 0;
  if (!hash_bytes(::fileno(file_), bytes, std::min(bytes, kTail), found) || found != tail)
    throw foreign("its last " + std::to_string(std::min(bytes, kTail)) +
                  " bytes before the checkpoint's position are not the ones the checkpoint wrote");
  if (::ftruncate(::fileno(file_), bytes) != 0 || std::fseek(file_, bytes, SEEK_SET) != 0)
    throw std::invalid_argument("cannot continue '" + path + "': cannot cut it back to the checkpoint's " +
                                std::to_string(bytes) + " bytes: " + std::strerror(errno));
}

std::uint64_t CsvWriter::tail_hash() const {
  std::uint64_t hash = 0;
  if (stdout_ || !hash_bytes(::fileno(file_), written_, std::min(written_, kTail), hash)) return 0;
  return hash;
}

CsvWriter::~CsvWriter() {
  if (file_ && !stdout_) std::fclose(file_);
}

long CsvWriter::flush_to_disk() {
  if (std::fflush(file_) != 0 || (!stdout_ && ::fsync(::fileno(file_)) != 0))
    throw std::runtime_error("error writing '" + path_ + "': " + std::strerror(errno));
  return written_;
}

void CsvWriter::row(double t, ConstVecRef q, const Diagnostics& d) {
  char* p = buffer_;
  put(p, t);
  for (Eigen::Index i = 0; i < q.size(); ++i) put(p, q[i]);
  put(p, d.energy);
  put(p, d.energy_post);
  put(p, d.residual);
  p[-1] = '\n';
  write(buffer_, static_cast<std::size_t>(p - buffer_));
}

void CsvWriter::close() {
  const bool bad = std::ferror(file_) != 0;
  const int rc = stdout_ ? std::fflush(file_) : std::fclose(file_);
  file_ = nullptr;
  if (bad || rc != 0) throw std::runtime_error("error writing '" + path_ + "': " + std::strerror(errno));
}

void CsvWriter::write(const char* data, std::size_t size) {
  std::fwrite(data, 1, size, file_);
  written_ += static_cast<long>(size);
}

void CsvWriter::put(char*& p, double v) {
  if (p + kField > buffer_ + sizeof buffer_) {  // full: write what is there (never the whole row)
    write(buffer_, static_cast<std::size_t>(p - buffer_));
    p = buffer_;
  }
  p = std::to_chars(p, p + kField, v).ptr;
  *p++ = ',';
}

}  // namespace nonholo::scenarios
