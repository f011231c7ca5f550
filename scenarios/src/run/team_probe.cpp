// The run's threads against one thread, measured by the step's own timing (team_probe.hpp).
#include "run/team_probe.hpp"

#include <cstdio>
#include <utility>

namespace nonholo::scenarios {

TeamProbe::TeamProbe(int threads, std::function<void(int)> set_team, Clock clock)
    : threads_(threads), team_(threads), set_team_(std::move(set_team)), clock_(std::move(clock)) {
  if (!clock_)
    clock_ = [] { return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count(); };
}

void TeamProbe::set(int team) {
  if (team == team_) return;
  team_ = team;
  set_team_(team);
}

// A cycle: a block on the run's threads, a block on one, kProbeEvery blocks on the faster
// (per timed step).
void TeamProbe::before_step(long step) {
  if (threads_ == 1) return;
  if (first_step_ < 0) first_step_ = step;
  const long i = count_ - kWarmUp;
  if (i < 0) return;
  const long at = i % ((2 + kProbeEvery) * kBlock);
  if (at == 0) {
    many_ = one_ = 0.0;
    many_count_ = one_count_ = 0;
    set(threads_);
  } else if (at == kBlock) {
    set(1);
  } else if (at == 2 * kBlock) {
    const double many = many_count_ > 0 ? many_ / many_count_ : 0.0, one = one_count_ > 0 ? one_ / one_count_ : 0.0;
    if (many_count_ > 0 && one_count_ > 0 && one < many) {
      if (first_fallback_ < 0) first_fallback_ = step;
      if (many / one > slowdown_) {
        slowdown_ = many / one;
        many_step_ = many, one_step_ = one;
      }
      set(1);
    } else {
      set(threads_);
    }
  }
  start_ = clock_();
}

void TeamProbe::after_step(bool timed) {
  if (threads_ == 1) return;
  const long i = count_++ - kWarmUp;
  if (i < 0) return;
  const double elapsed = clock_() - start_;
  const long at = i % ((2 + kProbeEvery) * kBlock);
  if (at < kBlock) {
    if (timed) many_ += elapsed, ++many_count_;
  } else if (at < 2 * kBlock) {
    if (timed) one_ += elapsed, ++one_count_;
  } else if (team_ == 1) {
    ++steps_on_one_;
  }
}

std::string TeamProbe::note() const {
  if (first_fallback_ < 0) return "";
  char since[80] = "";
  if (first_step_ > 1) std::snprintf(since, sizeof since, " since the resume at step %ld", first_step_);
  char line[480];
  std::snprintf(line, sizeof line,
                "the chain's %d threads ran a step slower than one thread (%.3g against %.3g ms: the cores are "
                "busy, or the chain is too short for them), first at step %ld; its %d partitions ran on one "
                "thread for %ld of the %ld steps%s (the same results, bit for bit)",
                threads_, 1e3 * many_step_, 1e3 * one_step_, first_fallback_, threads_, steps_on_one_, count_, since);
  return line;
}

}  // namespace nonholo::scenarios
