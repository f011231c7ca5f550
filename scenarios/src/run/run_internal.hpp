#pragma once
// The pieces of `nonholo run` that `nonholo batch` and runs of models built in code share: option
// checking once (prepare_run, prepare_model_run), then one trajectory at a time (integrate_model;
// integrate_scene builds the scene's model for a set of parameters and calls it).
#include <nonholo/scenarios/run_types.hpp>

#include <chrono>
#include <functional>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "run/progress.hpp"
#include "run/runners.hpp"

namespace nonholo::scenarios {

// max that lets a NaN through instead of hiding it (a blown-up trajectory must show).
inline double worst(double so_far, double value) {
  return (value != value || value > so_far) ? value : so_far;
}

// The methods of the index-reduced equations (reference/): hitches as velocity rows, --project.
inline bool reference_method(const std::string& name) {
  return name == "rk4" || name == "arkode-dp5" || name == "arkode-verner" || name == "arkode-fehlberg8";
}

// A checkpoint resumed with a model whose fingerprint (model_fingerprint.hpp) is not the one saved.
inline std::invalid_argument wrong_model(const std::string& checkpoint) {
  return std::invalid_argument("--resume " + checkpoint + ": the model is not the one the checkpoint was written with "
                               "(its sizes, names or masses differ): resume with that model");
}

struct PreparedRun {
  SceneInfo info;  // a built-in scene or one read from a file (a model built in code: its name only)
  bool from_code = false;  // a model built in code (run_model): no scene to build it again
  double t0 = 0.0;  // the start time (the scenes': 0); the run takes steps from t0 to t_end
  MethodChoice choice;
  Companion companion;  // --error-estimate
  Companion check;      // the accuracy check's (RunConfig::accuracy_check)
  double dt = 0.0;
  double t_end = 0.0;  // the one used (the scene's when the config gave none)
  long steps = 0;
  std::string resume;  // checkpoint bytes to continue from (empty: a fresh start)
};

// Validates the options of `config` (throws std::invalid_argument with the option's name).
PreparedRun prepare_run(const RunConfig& config);
// ... for a model built in code that starts at t0: config.scene its name, dt and t_end required.
PreparedRun prepare_model_run(const RunConfig& config, double t0);

// Who watches a trajectory and what it should keep besides its summary.
struct TrajectoryHooks {
  Progress* progress = nullptr;      // the steps done; restarted when they begin
  Progress* setup_status = nullptr;  // the phases of the set-up (Progress::status); may be `progress`
  // Called once the model is built, before the method starts (which may still fail): a batch
  // takes the coordinate names of its table from it.
  std::function<void(const Model&)> on_model;
  bool final_q = false;      // TrajectoryResult::final_q
  bool final_state = false;  // TrajectoryResult::final_p and the names (`nonholo batch --states`)
  // When the run began (run_scene's start, before its checkpoint was read): the HDF5 file's
  // wall_s counts from it. Unset: the trajectory's own start.
  std::optional<std::chrono::steady_clock::time_point> started;
};

// What one trajectory gives back.
struct TrajectoryResult {
  RunSummary summary;  // wall_s: up to the output file's closing (the caller sets its own)
  Vector final_q, final_p;
  std::vector<std::string> coordinates, velocities;  // the names of final_q's and final_p's entries
};

// One trajectory of `model` from `start`: the phases of run_loop.hpp (the CSV or HDF5 output if
// config.csv_path is set). `params`: the scene's, for the HDF5 file's attributes (a model built in
// code: none). `release_start`, if given, is called once the methods have started from `start`,
// which is not read again (a scene's frees it: a million-body chain's is 48 MB). Throws
// std::invalid_argument on a bad set-up.
TrajectoryResult integrate_model(const PreparedRun& run, const Model& model, const RunStart& start,
                                 const Parameters& params, const RunConfig& config, const TrajectoryHooks& hooks = {},
                                 const std::function<void()>& release_start = {});
// One trajectory of the prepared scene with these parameters: its model built, then integrate_model.
TrajectoryResult integrate_scene(const PreparedRun& run, const Parameters& params, const RunConfig& config,
                                 const TrajectoryHooks& hooks = {});

}  // namespace nonholo::scenarios
