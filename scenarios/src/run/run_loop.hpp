#pragma once
// One trajectory of `nonholo run` (and of each row of `nonholo batch`) as named phases:
//   set_up -> open_outputs -> describe_run -> start | resume -> loop of steps -> close -> judge
// RunLoop holds what the phases share; integrate_model (run_internal.hpp) runs them in order, for
// a scene's model (integrate_scene) as for one built in code (run_model).
// The step itself is the method's (runners.hpp); the bounds each step is held to are
// run_checks.hpp's, the verdicts at the end verdicts.hpp's.
#include <nonholo/accuracy.hpp>
#include <nonholo/archive.hpp>
#include <nonholo/diagnostics.hpp>
#include <nonholo/scenarios/run_types.hpp>

#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "output/csv_writer.hpp"
#include "output/file_lock.hpp"
#include "output/hdf5_output.hpp"
#include "run/run_checks.hpp"
#include "run/run_internal.hpp"
#include "run/stability_watch.hpp"
#include "run/stop_watch.hpp"
#include "run/team_probe.hpp"

namespace nonholo::scenarios {

// The scales of a body at rest (initial energy 0: a disk standing under gravity, where the
// errors compared round-off with round-off and read 1): the kinetic energy one step of the applied
// force f(t0, q0) gives from rest, (1/2)|h f|^2_{M^-1}, and the speed, |h M^-1 f|_inf. Round-off
// in the work, the energy and the velocity is eps times these; a moving body is far above them.
struct RestScales {
  double energy = 0.0, speed = 0.0;
};

// What the run loop carries from one step to the next besides the runner and the watches: what
// a checkpoint saves of it (every value the later steps or the summary read).
struct LoopState {
  long k = 0;       // steps done
  double t0 = 0.0;  // the run's start: step k ends at t0 + k dt
  RunSummary summary;
  Diagnostics d0;   // at the start: the energy errors are relative to it
  double power0 = 0.0, power = 0.0;
  WorkIntegral work;
  RestScales rest;
  Vector j0;        // the momentum maps at the start
  double lever_arm = 0.0;
  double difference = 0.0;  // --error-estimate: max over the output times of |q - q^|_inf
  std::string companion_failure;
  // The accuracy check's companion (check_step): the max of |q - q_check|_inf so far, why it
  // stopped if it failed, and (adaptive steps, which have no sampled check) the range of q.
  double check_difference = 0.0;
  std::string check_failure;
  bool check_stepped = false;  // it has stepped since it (re)started (reseed_check)
  Extent range;
  long output_position = 0;  // CSV: bytes written; HDF5: frames
  std::uint64_t output_tail = 0;  // CSV: the hash of its last bytes before output_position
  std::string run_id;        // 16 random hex digits, a fresh run's: in its HDF5 output and checkpoints
  double seconds = 0.0;      // integration time so far (ns_per_step of a resumed run)

  void save(OutArchive& a) const;
  void load(InArchive& a);
};

class RunLoop {
 public:
  // `started`: when the trajectory began (a scene's: before its model was built).
  RunLoop(const PreparedRun& run, const Model& model, const RunStart& start, const Parameters& params,
          const RunConfig& config, const TrajectoryHooks& hooks, std::function<void()> release_start,
          std::chrono::steady_clock::time_point started);
  // The phases in order; throws std::invalid_argument on a bad set-up (before any step).
  TrajectoryResult run();

 private:
  using Clock = std::chrono::steady_clock;

  // --- the phases, in the order run() calls them ---
  void set_up();         // the methods (and the companions of the checks and --error-estimate)
  void read_loop_state();  // a resumed run: the loop's state from the checkpoint
  void open_outputs();   // CSV or HDF5, and the caller's sink
  void describe_run();   // the summary's fixed fields: scene, method, order, hitch, ...
  void start();          // a fresh run: the initial diagnostics, the first frame, the initial checks
  void make_watches();   // the stability and precision watches (start and resume)
  void resume();         // a resumed run: the runner's and the watches' state from the checkpoint
  void loop();           // the steps, until t_end or a failure
  void close_outputs();  // the final checkpoint, estimates, the files closed
  void judge();          // the summary's last fields, warnings and the accuracy verdict
  TrajectoryResult result();
  TrajectoryResult interrupted_in_set_up();  // a stop request before the first step's set-up ended

  // --- one step of the loop ---
  bool stop_requested(long k);       // Ctrl-C, the sink or the caller: status=interrupted
  bool stop_signalled() const;      // whether one of them asks to stop (the runners ask it too)
  std::string stop_cause() const;    // "interrupted (SIGINT)" or "interrupted by the caller"
  void interrupted(long k, bool during);  // status=interrupted, after step k - 1 or during step k
  bool watches_fail(long k);         // the stability and precision watches before step k
  bool advance(long k);              // the method's step; false (status set) when it failed
  bool stop_condition_holds(long k);  // a stop condition held after step k (0: at the start)
  Diagnostics measure(long k);       // the step's diagnostics, held to the energy, residual and gap bounds
  void companion_step(long k, bool output);
  void check_step(long k);
  bool reseed_check();
  bool wants_check_companion() const;
  void include_in_extent();  // adaptive steps: the range of q
  double largest_coordinate() const;  // ... and its largest |q_i|
  void estimate_from_check();  // close_outputs: the accuracy check's estimate and extent
  void write_frame(const Diagnostics& d);
  void checkpoint_if_due(long k);
  void write_checkpoint_now(long k);

  double relative_residual();  // of the runner's velocity; 0 for a body at rest
  double power_now();          // F(t, q)^T v

  const PreparedRun& run_;
  const Model& model_;
  const RunStart& start_;              // read by set_up only ...
  std::function<void()> release_start_;  // ... which then calls this (integrate_model)
  const Parameters& params_;
  const RunConfig& config_;
  const TrajectoryHooks& hooks_;
  const bool reflection_;

  std::string fingerprint_;  // the model's (model_fingerprint): in checkpoints, compared on resume
  std::unique_ptr<Runner> runner_, companion_;
  std::unique_ptr<Runner> check_;  // the accuracy check's companion (RunConfig::accuracy_check)
  bool check_companion_ = false;   // chosen for this run (check_ may since have failed)
  std::unique_ptr<StabilityWatch> stability_;
  std::unique_ptr<PrecisionWatch> precision_;
  std::unique_ptr<StopWatch> stops_;  // the run's stop conditions (none: null)
  std::unique_ptr<InArchive> archive_;  // a resumed run's checkpoint, read in phases
  LoopState loop_;
  RunSummary summary_;

  FileLock output_lock_, checkpoint_lock_;  // no second run writes these while this one does
  std::unique_ptr<CsvWriter> csv_;
  std::unique_ptr<Hdf5RunWriter> h5_;
  std::vector<FrameSink*> sinks_;

  bool forced_ = false;      // external forces: the energy balance against the work
  bool exact_work_ = false;  // ... by the order-2 reflection step's discrete identity
  Vector force_, j_;         // scratch: F(t, q), the momentum maps
  double speed_floor_ = 0.0;
  std::string thread_warning_;  // set_up's: threads asked for that do not all help
  std::optional<TeamProbe> team_probe_;  // the run's threads against one, as the load changes

  Clock::time_point run_start_, loop_start_, last_checkpoint_, last_flush_;
  double output_s_ = 0.0, companion_s_ = 0.0, loop_s_ = 0.0;
};

}  // namespace nonholo::scenarios
