#pragma once
// A progress bar on stderr for long runs, drawn only when stderr is a terminal or
// NONHOLO_PROGRESS=1 (nothing at all otherwise, so pipes and files get clean output), with the
// time left. Before it, status() shows what a long set-up is doing ("setting up sleigh_chain
// (1000000 bodies): analysing C..."); the bar, begin_steps() or finish() wipes it. Thread-safe:
// update() may be called from any thread; whichever gets the mutex redraws, at most ten times
// a second. Everything update() reads before taking the mutex is atomic. Verbosity 0 (--quiet)
// draws nothing; 2 (--verbose) writes lines where stderr is no terminal (a log): each set-up
// phase, and the progress every 10 s.
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <mutex>
#include <string>

#include <unistd.h>

namespace nonholo::scenarios {

class Progress {
 public:
  Progress(std::string label, long total, int verbosity = 1)
      : label_(std::move(label)),
        total_(total),
        enabled_(total > 0 && verbosity > 0 && (isatty(fileno(stderr)) || forced() || verbosity >= 2)),
        lines_(verbosity >= 2 && !isatty(fileno(stderr)) && !forced()),
        start_(Clock::now()) {}
  ~Progress() { finish(); }

  // One status line for the set-up, drawn at once (a set-up step can take seconds at a million
  // bodies), replacing the previous one. Shorter than a terminal line, so that \r redraws it.
  void status(const std::string& text) {
    if (!enabled_) return;
    std::lock_guard<std::mutex> lock(mutex_);
    if (lines_) {
      std::fprintf(stderr, "%s\n", text.c_str());
      std::fflush(stderr);
      return;
    }
    const std::string line = text.size() > kStatusWidth ? text.substr(0, kStatusWidth) : text;
    std::fprintf(stderr, "\r%-*s", std::max(shown_, static_cast<int>(line.size())), line.c_str());
    std::fflush(stderr);
    shown_ = static_cast<int>(line.size());
    status_shown_ = true;
  }
  // Wipes the status line (if one is shown) and restarts the clock of the time left: a run
  // calls it when its steps begin, so that the set-up does not count in their rate.
  void begin_steps() {
    std::lock_guard<std::mutex> lock(mutex_);
    start_ns_offset_.store(since_clock_ns(), std::memory_order_relaxed);
    last_ns_.store(0, std::memory_order_relaxed);
    if (!status_shown_) return;
    clear_line();
    status_shown_ = false;
  }

  void add(long done) {  // no shared write when nothing is drawn (a batch's threads call it)
    if (enabled_) update(done_ += done);
  }
  void update(long done) {
    if (!enabled_) return;
    const std::int64_t now = since_start_ns(), every = lines_ ? kLineNs : kRedrawNs;
    if (now < (lines_ ? kLineNs : kFirstDrawNs) || now - last_ns_.load(std::memory_order_relaxed) < every) return;
    std::unique_lock<std::mutex> lock(mutex_, std::try_to_lock);
    if (!lock) return;
    last_ns_.store(now, std::memory_order_relaxed);
    if (status_shown_) {  // the bar replaces the set-up's status line
      clear_line();
      status_shown_ = false;
    }
    const double f = static_cast<double>(done) / static_cast<double>(total_);
    const int width = 30, filled = static_cast<int>(f * width);
    std::string bar(static_cast<std::size_t>(filled), '#');
    bar.resize(width, '.');
    const double left = f > 0.0 ? 1e-9 * static_cast<double>(now) * (1.0 - f) / f : -1.0;
    if (lines_) {
      std::fprintf(stderr, "%s: %5.1f%% %s\n", label_.c_str(), 100.0 * f, format_eta(left).c_str());
      std::fflush(stderr);
      return;
    }
    std::fprintf(stderr, "\r%s [%s] %5.1f%% %s", label_.c_str(), bar.c_str(), 100.0 * f, format_eta(left).c_str());
    std::fflush(stderr);
    shown_ = static_cast<int>(label_.size()) + kLineExtra;
  }
  // The time left (seconds; negative: unknown) at the mean rate so far, fixed width:
  // "ETA     1m05s", "ETA   2h03m04s", "ETA    --    ".
  static std::string format_eta(double seconds) {
    if (!(seconds >= 0.0) || seconds > 3.6e8) return "ETA    --    ";
    const long left = static_cast<long>(seconds + 0.5);
    char text[40];
    if (left >= 3600)
      std::snprintf(text, sizeof text, "ETA %3ldh%02ldm%02lds", left / 3600, left / 60 % 60, left % 60);
    else
      std::snprintf(text, sizeof text, "ETA %6ldm%02lds", left / 60, left % 60);
    return text;
  }

  void finish() {
    std::lock_guard<std::mutex> lock(mutex_);
    clear_line();
    status_shown_ = false;
  }

 private:
  using Clock = std::chrono::steady_clock;
  static constexpr std::int64_t kFirstDrawNs = 500'000'000, kRedrawNs = 100'000'000;
  static constexpr std::int64_t kLineNs = 10'000'000'000;  // --verbose in a log: a line every 10 s
  static constexpr int kLineExtra = 58;  // " [bar] 100.0% ETA 99h59m59s" and some room
  static constexpr std::size_t kStatusWidth = 79;

  // Under mutex_: blanks what is shown and returns to the start of the line.
  void clear_line() {
    if (shown_ == 0) return;
    std::fprintf(stderr, "\r%*s\r", shown_, "");
    std::fflush(stderr);
    shown_ = 0;
  }
  std::int64_t since_clock_ns() const {
    return std::chrono::duration_cast<std::chrono::nanoseconds>(Clock::now() - start_).count();
  }
  std::int64_t since_start_ns() const {
    return since_clock_ns() - start_ns_offset_.load(std::memory_order_relaxed);
  }
  static bool forced() {
    const char* v = std::getenv("NONHOLO_PROGRESS");
    return v && std::string(v) == "1";
  }

  std::string label_;
  long total_;
  bool enabled_;
  bool lines_;  // lines for a log (--verbose, stderr no terminal) instead of a bar redrawn in place
  std::atomic<long> done_{0};
  Clock::time_point start_;
  std::atomic<std::int64_t> last_ns_{0};  // read before the mutex is taken: atomic
  std::atomic<std::int64_t> start_ns_offset_{0};  // begin_steps(): where the steps' clock starts
  std::mutex mutex_;
  int shown_ = 0;              // under mutex_: width of what is on the line (0: nothing)
  bool status_shown_ = false;  // under mutex_: that is a status line
};

}  // namespace nonholo::scenarios
