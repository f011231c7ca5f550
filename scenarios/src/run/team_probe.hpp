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

  // `step`: the run's number of the step about to run (1, 2, ...; a resumed run's continue).
  void before_step(long step);
  // Of a step that succeeded; `timed`: its time is the step's alone (not a step that also ran
  // the accuracy check's shadow step, which would weigh on one block and not the other).
  void after_step(bool timed = true);

  int team() const { return team_; }
  long steps_on_one() const { return steps_on_one_; }  // steps run on one thread after a probe chose it
  // Empty, or what the summary says when one thread was faster (RunSummary::threads_note).
  std::string note() const;

 private:
  int threads_, team_;
  std::function<void(int)> set_team_;
  Clock clock_;
  long count_ = 0;     // steps seen
  long first_step_ = -1;  // the first step seen (a resumed run's is not 1)
  double start_ = 0.0;
  double many_ = 0.0, one_ = 0.0;  // this probe's timed steps' times on each team, and their number
  int many_count_ = 0, one_count_ = 0;
  long first_fallback_ = -1, steps_on_one_ = 0;
  double slowdown_ = 0.0;  // the largest ratio (P threads / one) a probe measured when it fell back
  double many_step_ = 0.0, one_step_ = 0.0;  // that probe's times per step
  void set(int team);
};

}  // namespace nonholo::scenarios
