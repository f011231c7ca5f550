#pragma once
// The pieces of `nonholo run` that `nonholo batch` shares: option checking once, then one
// trajectory at a time from a given set of parameters.
#include <nonholo/scenarios/run.hpp>

#include "progress.hpp"
#include "runners.hpp"

#include <string>
#include <vector>

namespace nonholo::scenarios {

// max that lets a NaN through instead of hiding it (a blown-up trajectory must show).
inline double worst(double so_far, double value) {
  return (value != value || value > so_far) ? value : so_far;
}

struct PreparedRun {
  SceneInfo info;  // a built-in scene or one read from a file
  MethodChoice choice;
  Companion companion;  // --error-estimate
  double dt = 0.0;
  double t_end = 0.0;  // the one used (the scene's when the config gave none)
  long steps = 0;
  std::string resume;  // checkpoint bytes to continue from (empty: a fresh start)
};

// Validates the options of `config` (throws std::invalid_argument with the option's name).
PreparedRun prepare_run(const RunConfig& config);
// One trajectory of the prepared run with these parameters: the summary (wall_s left 0),
// the CSV if config.csv_path is set, and the final configuration if final_q is given.
// `progress` (may be null) gets the steps done and is restarted when they begin; `setup_status` (may
// be null, may be the same) shows the phases of the set-up (Progress::status); `leading_names`
// (if given) receives the first three coordinate names of the model (fewer if it has fewer).
// The whole final state and its names (`nonholo batch --states`).
struct FinalState {
  Vector p;
  std::vector<std::string> coordinates, velocities;
};
RunSummary integrate_scene(const PreparedRun& run, const Parameters& params, const RunConfig& config,
                           Progress* progress, Vector* final_q, Progress* setup_status = nullptr,
                           std::vector<std::string>* leading_names = nullptr, FinalState* final_state = nullptr);

}  // namespace nonholo::scenarios
