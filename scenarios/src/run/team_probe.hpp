#pragma once
// Threads only where cores are free (docs/design.md, "One chain on several threads"): on a
// machine whose cores are busy a barrier waits for a descheduled thread, and P threads run a
// step slower than one. A run on P threads times a block of steps on them and a block on one
// thread (the same partitions in turn, Workspace::set_team: bit for bit the same results),
// keeps the faster for the next kProbeEvery blocks, and probes again as the load changes.
#include <chrono>
#include <functional>
#include <string>

namespace nonholo::scenarios {

class TeamProbe {
 public:
  static constexpr int kWarmUp = 2;       // steps not timed (the first factorises in natural order)
  static constexpr int kBlock = 8;        // steps timed on each team
  static constexpr int kProbeEvery = 64;  // blocks on the chosen team between probes

  using Clock = std::function<double()>;  // seconds
  // `threads`: the run's (1: the probe does nothing); `set_team` sets the threads that run
  // them; `clock`: the steady clock unless a test gives its own.
  TeamProbe(int threads, std::function<void(int)> set_team, Clock clock = {});

  void before_step();
  void after_step();  // of a step that succeeded

  int team() const { return team_; }
  long steps_on_one() const { return steps_on_one_; }  // steps run on one thread after a probe chose it
  // Empty, or what the summary says when one thread was faster (RunSummary::threads_note).
  std::string note(long steps) const;

 private:
  int threads_, team_;
  std::function<void(int)> set_team_;
  Clock clock_;
  long count_ = 0;     // steps seen
  double start_ = 0.0;
  double many_ = 0.0, one_ = 0.0;  // this probe's block times
  long first_fallback_ = -1, steps_on_one_ = 0;
  double slowdown_ = 0.0;  // the largest ratio (P threads / one) a probe measured when it fell back
  double many_step_ = 0.0, one_step_ = 0.0;  // that probe's times per step
  void set(int team);
};

}  // namespace nonholo::scenarios
