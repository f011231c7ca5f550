// The batch's table as CSV and the journal of finished rows (batch_table.hpp).
#include "output/batch_table.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <sstream>
#include <stdexcept>

namespace nonholo::scenarios {
namespace {

// Numbers as std::to_chars writes them (the shortest text that reads back the same double).
template <class T>
void append_number(std::string& out, T x) {
  char buf[32];
  out.append(buf, std::to_chars(buf, buf + sizeof buf, x).ptr);
}

// The batch table's CSV header and rows (`nonholo batch --out`, and the journal below).
void csv_header(std::ostream& out, const std::vector<std::string>& varied, const std::vector<std::string>& shown,
                bool has_work, bool error_estimate) {
  out << "trajectory";
  for (const auto& name : varied) out << "," << name;
  out << ",t_final";
  for (const auto& name : shown) out << "," << name;
  out << ",energy_rel_err_max,energy_post_rel_err_max,residual_max,gap_max,restarts,parasitic_max";
  if (has_work) out << ",work,energy_balance_err_max";
  if (error_estimate) out << ",error_estimate";
  out << ",status\n";
}

// Appended to a string: the journal's threads and the table's formatting threads share no stream.
void csv_row(std::string& out, long i, const BatchResult::Trajectory& r, bool has_work, bool error_estimate) {
  const RunSummary& s = r.summary;
  auto field = [&out](double x) {
    out += ',';
    append_number(out, x);
  };
  append_number(out, i);
  for (double x : r.values) field(x);
  field(s.t_final);
  for (double x : r.final_q) field(x);
  field(s.energy_rel_err_max), field(s.energy_post_rel_err_max), field(s.residual_max), field(s.gap_max);
  out += ',';
  append_number(out, s.restarts);
  field(s.parasitic_max);
  if (has_work) field(s.has_work ? s.work : NAN), field(s.energy_balance_err_max);
  if (error_estimate) field(s.error_estimate);
  out += ',';
  out += to_string(s.status);
  out += '\n';
}

}  // namespace

// The rows formatted on the batch's threads, a window at a time (the text of 64 Ki rows, about
// 10 MB, held at once), and written in order: 200 000 single sleighs' rows took 0.21 s on one.
void write_batch_csv(std::ofstream& out, const std::string& path, const BatchResult& result, bool error_estimate) {
  const bool has_work = result.aggregate.has_work;
  csv_header(out, result.varied, result.shown, has_work, error_estimate);
  constexpr long kPiece = 1024, kWindow = 64;  // rows a piece, pieces a window
  const long rows = static_cast<long>(result.rows.size());
  std::vector<std::string> pieces(kWindow);
  for (long first = 0; first < rows; first += kPiece * kWindow) {
    const long count = std::min(kWindow, (rows - first + kPiece - 1) / kPiece);
#pragma omp parallel for schedule(dynamic, 1) num_threads(std::max(1, result.threads))
    for (long k = 0; k < count; ++k) {
      std::string& text = pieces[static_cast<std::size_t>(k)];
      text.clear();
      const long from = first + k * kPiece, to = std::min(rows, from + kPiece);
      for (long i = from; i < to; ++i)
        csv_row(text, i, result.rows[static_cast<std::size_t>(i)], has_work, error_estimate);
    }
    for (long k = 0; k < count; ++k) out << pieces[static_cast<std::size_t>(k)];
  }
  out.close();
  if (!out) throw std::runtime_error("error writing '" + path + "'");
}

Journal::Journal(const std::string& out, const BatchProcesses* processes, bool error_estimate)
    : error_estimate_(error_estimate) {
  if (out.empty()) return;
  path_ = out + (processes && processes->size() > 1 ? ".partial.rank" + std::to_string(processes->rank()) : ".partial") +
          ".csv";
  // A new file only: one already there is the journal of a batch that did not finish (its finished
  // rows) or a file of the user's, and a link there is not followed (it was emptied, then removed).
  fd_ = ::open(path_.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_NOFOLLOW | O_APPEND | O_CLOEXEC, 0666);
  if (fd_ < 0 && errno == EEXIST)
    throw std::invalid_argument("'" + path_ + "' exists: the journal of an earlier batch with --out " + out +
                                " that did not finish (its finished rows; nonholo.load reads it), or a file of " +
                                "yours. A batch does not write over it: move or remove it");
  if (fd_ < 0) throw std::invalid_argument("cannot open '" + path_ + "' for writing: " + std::strerror(errno));
}

Journal::~Journal() {  // a batch that failed keeps the rows it finished
  if (fd_ < 0) return;
  flush();
  ::close(fd_);
}

// O_APPEND: each write lands whole at the end of the file, however many threads write. A
// journal is a safety net beside the output written at the end: a failed write (a full disk)
// loses the net, not the batch, and is not reported from the threads.
void Journal::append(const std::string& text) {
  const char* at = text.data();
  std::size_t left = text.size();
  while (left > 0) {
    const ssize_t n = ::write(fd_, at, left);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return;
    at += n;
    left -= static_cast<std::size_t>(n);
  }
}

void Journal::begin(int threads) {
  if (fd_ < 0 || blocks_) return;
  block_count_ = std::max(1, threads);
  blocks_ = std::make_unique<Block[]>(static_cast<std::size_t>(block_count_));
  flusher_ = std::thread([this] { flusher(); });
}

void Journal::write_block(Block& b) {
  append(b.text);
  b.text.clear();
}

void Journal::flusher() {
  std::unique_lock<std::mutex> lock(stop_mutex_);
  const auto delay = std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(kJournalDelay));
  while (!stop_.wait_for(lock, delay, [this] { return stopping_; })) {
    const auto due = Clock::now() - delay;
    for (int k = 0; k < block_count_; ++k) {
      Block& b = blocks_[static_cast<std::size_t>(k)];
      const std::lock_guard<std::mutex> held(b.mutex);
      if (!b.text.empty() && b.oldest <= due) write_block(b);
    }
  }
}

void Journal::add(long i, int thread, const BatchResult::Trajectory& row, const std::vector<std::string>& varied,
                  const std::vector<std::string>& names) {
  if (fd_ < 0) return;
  if (!header_.load(std::memory_order_acquire)) {
    const std::lock_guard<std::mutex> lock(header_mutex_);
    if (!header_.load(std::memory_order_relaxed)) {
      has_work_ = row.summary.has_work;
      std::ostringstream header;
      csv_header(header, varied,
                 std::vector<std::string>(names.begin(), names.begin() + static_cast<std::ptrdiff_t>(row.final_q.size())),
                 has_work_, error_estimate_);
      append(header.str());
      header_.store(true, std::memory_order_release);
    }
  }
  std::string line;
  csv_row(line, i, row, has_work_, error_estimate_);
  if (!blocks_) {  // begin() not called: a row at a time
    append(line);
    return;
  }
  Block& b = blocks_[static_cast<std::size_t>(thread) % static_cast<std::size_t>(block_count_)];
  const auto now = Clock::now();
  const std::lock_guard<std::mutex> lock(b.mutex);
  if (b.text.empty()) b.oldest = now;
  b.text += line;
  constexpr std::size_t kFull = std::size_t{1} << 16;
  if (b.text.size() >= kFull || std::chrono::duration<double>(now - b.oldest).count() >= kJournalDelay) write_block(b);
}

void Journal::flush() {
  if (flusher_.joinable()) {
    {
      const std::lock_guard<std::mutex> lock(stop_mutex_);
      stopping_ = true;
    }
    stop_.notify_all();
    flusher_.join();
  }
  for (int k = 0; k < block_count_; ++k) {
    Block& b = blocks_[static_cast<std::size_t>(k)];
    const std::lock_guard<std::mutex> lock(b.mutex);
    if (!b.text.empty() && fd_ >= 0) write_block(b);
  }
}

void Journal::remove() {
  if (fd_ < 0) return;
  flush();
  ::close(fd_);
  fd_ = -1;
  std::remove(path_.c_str());
}

}  // namespace nonholo::scenarios
