#pragma once
// A progress bar on stderr for long runs, drawn only when stderr is a terminal (nothing at
// all otherwise, so pipes and files get clean output). Thread-safe: update() may be called
// from any thread; one of them redraws at most ten times a second.
#include <atomic>
#include <chrono>
#include <cstdio>
#include <mutex>
#include <string>

#include <unistd.h>

namespace nonholo::scenarios {

class Progress {
 public:
  Progress(std::string label, long total)
      : label_(std::move(label)), total_(total), enabled_(total > 0 && isatty(fileno(stderr))),
        start_(std::chrono::steady_clock::now()), last_(start_) {}
  ~Progress() { finish(); }

  void add(long done) { update(done_ += done); }
  void update(long done) {
    if (!enabled_) return;
    const auto now = std::chrono::steady_clock::now();
    if (now - last_ < std::chrono::milliseconds(100) || now - start_ < std::chrono::milliseconds(500)) return;
    std::unique_lock<std::mutex> lock(mutex_, std::try_to_lock);
    if (!lock) return;
    last_ = now;
    const double f = static_cast<double>(done) / static_cast<double>(total_);
    const int width = 30, filled = static_cast<int>(f * width);
    std::string bar(static_cast<std::size_t>(filled), '#');
    bar.resize(width, '.');
    std::fprintf(stderr, "\r%s [%s] %5.1f%%", label_.c_str(), bar.c_str(), 100.0 * f);
    std::fflush(stderr);
    drawn_ = true;
  }
  void finish() {
    if (!drawn_) return;
    std::fprintf(stderr, "\r%*s\r", static_cast<int>(label_.size()) + 42, "");
    std::fflush(stderr);
    drawn_ = false;
  }

 private:
  std::string label_;
  long total_;
  bool enabled_;
  std::atomic<long> done_{0};
  std::chrono::steady_clock::time_point start_, last_;
  std::mutex mutex_;
  bool drawn_ = false;
};

}  // namespace nonholo::scenarios
