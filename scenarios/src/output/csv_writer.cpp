// The trajectory CSV of `nonholo run --out FILE.csv` (csv_writer.hpp): its header, rows,
// continuation after a checkpoint and the flushes that keep a killed run's rows on disk.
#include "output/csv_writer.hpp"

#include <unistd.h>

#include <cerrno>
#include <charconv>
#include <cstring>
#include <stdexcept>

namespace nonholo::scenarios {

CsvWriter::CsvWriter(const std::string& path, const std::vector<std::string>& coordinates)
    : path_(path == "-" ? "standard output" : path), stdout_(path == "-") {
  file_ = stdout_ ? stdout : std::fopen(path.c_str(), "w");
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

CsvWriter::CsvWriter(const std::string& path, long bytes) : path_(path), written_(bytes) {
  file_ = std::fopen(path.c_str(), "r+b");
  if (!file_)
    throw std::invalid_argument("cannot continue '" + path + "': cannot open it for writing: " + std::strerror(errno));
  std::fseek(file_, 0, SEEK_END);
  const long size = std::ftell(file_);
  if (size < bytes || ::ftruncate(::fileno(file_), bytes) != 0 || std::fseek(file_, bytes, SEEK_SET) != 0)
    throw std::invalid_argument("cannot continue '" + path + "': it holds " + std::to_string(size) +
                                " bytes where the checkpoint wrote " + std::to_string(bytes) +
                                ": not the output of this run");
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
