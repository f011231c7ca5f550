// `nonholo run` (run_scene): the options checked once into a PreparedRun (prepare_run, in
// phases: the method, the steps, the outputs, adaptive steps), a checkpoint's options for a
// resume, then one trajectory (run_loop.cpp).
#include <nonholo/scenarios/run.hpp>

#include <nonholo/scenarios/scene_file.hpp>

#include <nonholo/rattle.hpp>

#include <chrono>
#include <cmath>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "output/checkpoint/checkpoint_file.hpp"
#include "output/checkpoint/run_config_archive.hpp"
#include "output/file_identity.hpp"
#include "output/hdf5_output.hpp"
#include "run/run_internal.hpp"

namespace nonholo::scenarios {
namespace {

// A run takes at most this many steps (prepare_run).
constexpr double kMaxSteps = kMaxRunSteps;

// The accuracy check samples a pair of steps at least this often (nonholo/accuracy.hpp): about
// 2/64 = 3 % of a run's cost once the samples agree (a shadow step of 2h and a factorisation).
constexpr int kAccuracyEvery = 64;

// The method and its options (--method, --order, --rotation, --restart, --tol, --project ...).
void choose_method(const RunConfig& config, PreparedRun& r) {
  r.choice.method = config.method;
  r.choice.backend = config.backend;
  if (config.threads < 0)
    throw std::invalid_argument("--threads " + std::to_string(config.threads) +
                                ": give the threads for one step of the chain, or 0 to let the run choose");
  r.choice.rattle.h = r.dt;
  r.choice.rattle.hitch = config.hitch;
  set_restart(r.choice.rattle.restart, config.restart);
  r.choice.rattle.restart.tolerance = config.restart_tol;
  r.choice.rattle.restart.monitor_every = config.monitor_every;
  r.choice.rattle.order = config.order;
  r.choice.rattle.composition = composition_from_string(config.composition);
  r.choice.rattle.rotation = rotation_from_string(config.rotation);
  if (config.method != "reflection" && r.choice.rattle.rotation != RotationLagrangian::MoserVeselov)
    throw std::invalid_argument("--rotation applies to the reflection method only");
  if (config.method != "reflection" && (config.order != 2 || r.choice.rattle.composition != Composition::Auto))
    throw std::invalid_argument("--order and --composition apply to the reflection method only");
  try {
    composition_scheme(config.order, r.choice.rattle.composition);
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(std::string("--order/--composition: ") + e.what());
  }
  validate(r.choice.rattle);
  r.choice.reference.h = r.dt;
  r.choice.reference.tol = config.tol;
  r.choice.reference.project = config.project;
  reference::validate(r.choice.reference);
  if (!reference_method(config.method) && config.project)
    throw std::invalid_argument("--project applies to the methods rk4, arkode-dp5, arkode-verner and arkode-fehlberg8");
}

// Whole steps of size dt; the run ends at the first multiple of dt at or after t_end.
void count_steps(const RunConfig& config, double t_end, PreparedRun& r) {
  if (!std::isfinite(t_end)) throw std::invalid_argument("t_end must be finite");
  if (config.every < 1)
    throw std::invalid_argument("--every " + std::to_string(config.every) + ": must be at least 1");
  const double ratio = t_end / r.dt;
  if (!(ratio <= kMaxSteps)) {
    std::ostringstream os;
    os.precision(3);
    os << "t_end " << t_end << " / dt " << r.dt << " = " << ratio << " steps, more than the " << kMaxSteps
       << " a run may take (the one-body sleigh takes about 160 ns per step: 1e12 steps would take two days); "
          "shorten --t-end or lengthen --dt";
    throw std::invalid_argument(os.str());
  }
  r.steps = static_cast<long>(std::ceil(ratio * (1.0 - 1e-12)));
  r.t_end = t_end;
}

// --accuracy, --out and --checkpoint.
void check_outputs(const RunConfig& config, PreparedRun& r) {
  if (!(config.accuracy >= 0.0) || !std::isfinite(config.accuracy))
    throw std::invalid_argument("--accuracy " + std::to_string(config.accuracy) +
                                ": must be a fraction of the motion's extent, at least 0 (0: off)");
  r.choice.accuracy_every = config.accuracy > 0.0 ? kAccuracyEvery : 0;
  const std::string& check = config.accuracy_check;
  if (check != "auto" && check != "companion" && check != "sampled")
    throw std::invalid_argument("--accuracy-check " + check + ": auto, companion or sampled");
  if (check != "auto" && config.method != "reflection" && config.method != "rk4")
    throw std::invalid_argument("--accuracy-check " + check + ": the accuracy check is the reflection method's and "
                                "rk4's (method " + config.method + "); --error-estimate compares any method with a "
                                "companion");
  if (check == "sampled" && config.adaptive)
    throw std::invalid_argument("--accuracy-check sampled: adaptive steps (--tol) have no sampled check (their own "
                                "step doubling sets the step); their check is the companion at 10 tol");
  const std::string& out = config.csv_path;
  if (!out.empty() && !is_hdf5_path(out) && out != "-" &&
      !is_csv_path(out))
    throw std::invalid_argument("--out " + out +
                                ": name the file .csv (text) or .h5 / .hdf5 (HDF5), or give - for CSV on standard output");
  if (!config.checkpoint_path.empty() && out == "-")
    throw std::invalid_argument("--checkpoint with --out -: a resumed run cannot continue standard output; write to a file");
  // Two outputs in one file, or an output over an input: refused by file, not by name (a link to
  // the scene file given as --out overwrote it). A resumed run keeps its checkpoint up to date.
  std::vector<NamedPath> inputs{{"the scene file", is_scene_file(config.scene) ? config.scene : ""}};
  if (!config.resume_path.empty() &&
      !(!config.checkpoint_path.empty() && same_file(config.resume_path, config.checkpoint_path)))
    inputs.push_back({"the resumed checkpoint", config.resume_path});
  refuse_shared_files({{"--out", out}, {"--checkpoint", config.checkpoint_path}}, inputs);
  if (!config.checkpoint_path.empty() && config.method.rfind("arkode", 0) == 0)
    throw std::invalid_argument("--checkpoint: " + config.method +
                                ": ARKODE keeps its step-size controller's history inside SUNDIALS, which cannot save "
                                "it, so a resumed run would not be the same trajectory (checkpoints work for "
                                "reflection, dla-* and rk4)");
}

// --tol with the reflection method: adaptive composed steps.
void choose_adaptive(const RunConfig& config, PreparedRun& r) {
  if (config.method != "reflection")
    throw std::invalid_argument("adaptive steps are the reflection method's (method " + config.method + ")");
  r.choice.adaptive.tol = config.tol;
  // Order 2 restarts lambda~ at every step (adaptive.hpp): say so in the summary.
  if (config.order == 2) set_restart(r.choice.rattle.restart, "1");
  r.choice.adaptive.horizon = config.horizon > 0.0 ? config.horizon : r.t_end;  // the scenes start at t = 0
  try {
    validate(r.choice.adaptive);
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(std::string("--tol/--t-end: ") + e.what());
  }
  // The steps' own error control replaces the accuracy check's sampled doubling.
  r.choice.accuracy_every = 0;
  if (config.error_estimate)
    throw std::invalid_argument("--error-estimate applies to fixed steps: adaptive steps (--tol) control their error");
}

// The options of a resumed run: the checkpoint's, with the caller's t_end (if set), checkpoint
// settings (by default the checkpoint resumed from is kept up to date), sink and stop.
RunConfig resumed_config(const RunConfig& given, const std::string& bytes) {
  RunConfig saved;
  try {
    InArchive a(bytes);
    load(a, saved);
  } catch (const std::runtime_error& e) {
    throw std::invalid_argument("--resume " + given.resume_path + ": " + e.what());
  }
  if (given.t_end >= 0.0) saved.t_end = given.t_end;
  saved.checkpoint_path = given.checkpoint_path.empty() ? given.resume_path : given.checkpoint_path;
  saved.checkpoint_every_steps = given.checkpoint_every_steps;
  saved.checkpoint_every_seconds = given.checkpoint_every_seconds;
  saved.resume_path = given.resume_path;
  saved.sink = given.sink;
  saved.stop = given.stop;
  return saved;
}

}  // namespace

// The checks run in this order, so that of several bad options the same one is named first.
PreparedRun prepare_run(const RunConfig& config) {
  PreparedRun r;
  r.info = is_scene_file(config.scene) ? load_scene_file(config.scene) : find_scene(config.scene);
  if (is_scene_file(config.scene) && !config.assignments.empty())
    throw std::invalid_argument("--set does not apply to a scene file (" + config.scene + "): edit the file");
  r.dt = config.dt > 0.0 ? config.dt : r.info.default_dt;
  choose_method(config, r);
  count_steps(config, config.t_end >= 0.0 ? config.t_end : r.info.default_t_end, r);
  // The companion's choice as the method's so far (its accuracy check at the default schedule).
  if (config.error_estimate) r.companion = companion_of(r.choice);
  check_outputs(config, r);
  if (config.adaptive) choose_adaptive(config, r);
  r.check = check_companion_of(r.choice);  // run if RunLoop::set_up chooses it (RunConfig::accuracy_check)
  return r;
}

RunSummary run_scene(const RunConfig& given) {
  const auto start_time = std::chrono::steady_clock::now();
  std::string resume;
  if (!given.resume_path.empty()) {
    CheckpointInfo at;
    resume = read_checkpoint(given.resume_path, &at);
    // An end before the checkpoint ran no step and ended ok at the checkpoint's time.
    if (given.t_end >= 0.0 && given.t_end < at.t) {
      std::ostringstream os;
      os << "--t-end " << given.t_end << " is before the checkpoint's t = " << at.t << " (" << given.resume_path
         << "): a resumed run goes on from there; give a later end, or none for the run's own";
      throw std::invalid_argument(os.str());
    }
  }
  const RunConfig config = resume.empty() ? given : resumed_config(given, resume);
  PreparedRun run = prepare_run(config);
  run.resume = std::move(resume);
  Parameters params = run.info.defaults();
  for (const auto& a : config.assignments) params.assign(a);
  Progress progress(run.info.name, run.steps);
  TrajectoryHooks hooks;
  hooks.progress = hooks.setup_status = &progress;
  hooks.started = start_time;
  RunSummary summary = integrate_scene(run, params, config, hooks).summary;
  progress.finish();
  summary.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start_time).count();
  return summary;
}

}  // namespace nonholo::scenarios
