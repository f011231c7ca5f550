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

// A cycle: a block on the run's threads, a block on one, kProbeEvery blocks on the faster.
void TeamProbe::before_step() {
  if (threads_ == 1) return;
  const long i = count_ - kWarmUp;
  if (i < 0) return;
  const long at = i % ((2 + kProbeEvery) * kBlock);
  if (at == 0) {
    many_ = one_ = 0.0;
    set(threads_);
  } else if (at == kBlock) {
    set(1);
  } else if (at == 2 * kBlock) {
    if (one_ < many_) {
      if (first_fallback_ < 0) first_fallback_ = count_;
      if (many_ / one_ > slowdown_) {
        slowdown_ = many_ / one_;
        many_step_ = many_ / kBlock, one_step_ = one_ / kBlock;
      }
      set(1);
    } else {
      set(threads_);
    }
  }
  start_ = clock_();
}

void TeamProbe::after_step() {
  if (threads_ == 1) return;
  const long i = count_++ - kWarmUp;
  if (i < 0) return;
  const double elapsed = clock_() - start_;
  const long at = i % ((2 + kProbeEvery) * kBlock);
  if (at < kBlock)
    many_ += elapsed;
  else if (at < 2 * kBlock)
    one_ += elapsed;
  else if (team_ == 1)
    ++steps_on_one_;
}

std::string TeamProbe::note(long steps) const {
  if (first_fallback_ < 0) return "";
  char line[400];
  std::snprintf(line, sizeof line,
                "the chain's %d threads ran a step slower than one thread (%.3g against %.3g ms: the cores are "
                "busy, or the chain is too short for them), first at step %ld; its %d partitions ran on one "
                "thread for %ld of %ld steps (the same results, bit for bit)",
                threads_, 1e3 * many_step_, 1e3 * one_step_, first_fallback_ + 1, threads_, steps_on_one_, steps);
  return line;
}

}  // namespace nonholo::scenarios
