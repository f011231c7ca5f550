// `nonholo run` (run_scene) and runs of models built in code (run_model): the options checked
// once into a PreparedRun (prepare_run, prepare_model_run, in phases: the method, the steps, the
// outputs, adaptive steps), a checkpoint's options for a resume, then one trajectory (run_loop.cpp).
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
#include "output/checkpoint/model_fingerprint.hpp"
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

// Whole steps of size dt from r.t0; the run ends at the first multiple of dt at or after t_end.
void count_steps(const RunConfig& config, double t_end, PreparedRun& r) {
  if (!std::isfinite(t_end)) throw std::invalid_argument("t_end must be finite");
  if (config.every < 1)
    throw std::invalid_argument("--every " + std::to_string(config.every) + ": must be at least 1");
  const double ratio = (t_end - r.t0) / r.dt;
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
  r.choice.adaptive.horizon = config.horizon > 0.0 ? config.horizon : r.t_end - r.t0;
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
// settings (by default the checkpoint resumed from is kept up to date), sink, stop flag and stop
// conditions in code; and what the run integrated.
RunConfig resumed_config(const RunConfig& given, const std::string& bytes, RunSource& source) {
  RunConfig saved;
  try {
    InArchive a(bytes);
    load(a, saved);
    load(a, source);
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
  saved.stop_conditions = given.stop_conditions;
  saved.verbosity = given.verbosity;
  return saved;
}

// The checks after the scene or model (r.info, r.t0), in this order, so that of several bad
// options the same one is named first.
void check_options(const RunConfig& config, double t_end, PreparedRun& r) {
  choose_method(config, r);
  count_steps(config, t_end, r);
  // The companion's choice as the method's so far (its accuracy check at the default schedule).
  if (config.error_estimate) r.companion = companion_of(r.choice);
  check_outputs(config, r);
  if (config.adaptive) choose_adaptive(config, r);
  r.check = check_companion_of(r.choice);  // run if RunLoop::set_up chooses it (RunConfig::accuracy_check)
}

// A run's summary once its trajectory has ended: the whole run's wall time.
RunSummary finished(TrajectoryResult&& result, Progress& progress, std::chrono::steady_clock::time_point start_time) {
  progress.finish();
  RunSummary summary = std::move(result.summary);
  summary.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start_time).count();
  return summary;
}

// The checkpoint to resume from (empty: none), refused when `t_end` is before it.
std::string checkpoint_to_resume(const RunConfig& given) {
  if (given.resume_path.empty()) return {};
  CheckpointInfo at;
  std::string bytes = read_checkpoint(given.resume_path, &at);
  // An end before the checkpoint ran no step and ended ok at the checkpoint's time.
  if (given.t_end >= 0.0 && given.t_end < at.t) {
    std::ostringstream os;
    os << "--t-end " << given.t_end << " is before the checkpoint's t = " << at.t << " (" << given.resume_path
       << "): a resumed run goes on from there; give a later end, or none for the run's own";
    throw std::invalid_argument(os.str());
  }
  return bytes;
}

// A State to start from: the model's sizes and finite values (its consistency is the caller's).
void check_start_state(const Model& model, const State& s) {
  const Eigen::Index nq = model.num_configuration(), nv = model.num_velocities(), m = model.num_one_forms();
  if (s.q.size() != nq || s.p.size() != nv || s.lambda.size() != m || s.force.size() != nv)
    throw std::invalid_argument("the start's state has " + std::to_string(s.q.size()) + " configuration entries, " +
                                std::to_string(s.p.size()) + " momenta, " + std::to_string(s.lambda.size()) +
                                " multipliers and " + std::to_string(s.force.size()) + " forces; the model has " +
                                std::to_string(nq) + ", " + std::to_string(nv) + ", " + std::to_string(m) + " and " +
                                std::to_string(nv) + ": start the state for this model");
  if (!std::isfinite(s.t) || !s.q.allFinite() || !s.p.allFinite() || !s.lambda.allFinite() || !s.force.allFinite())
    throw std::invalid_argument("the start's state is not finite (its t, q, p, lambda or force): start it again");
}

}  // namespace

PreparedRun prepare_run(const RunConfig& config) {
  PreparedRun r;
  r.info = is_scene_file(config.scene) ? load_scene_file(config.scene) : find_scene(config.scene);
  if (is_scene_file(config.scene) && !config.assignments.empty())
    throw std::invalid_argument("--set does not apply to a scene file (" + config.scene + "): edit the file");
  r.dt = config.dt > 0.0 ? config.dt : r.info.default_dt;
  check_options(config, config.t_end >= 0.0 ? config.t_end : r.info.default_t_end, r);
  return r;
}

PreparedRun prepare_model_run(const RunConfig& config, double t0) {
  PreparedRun r;
  r.from_code = true;
  r.t0 = t0;
  r.info.name = config.scene.empty() ? "model" : config.scene;
  if (is_scene_file(r.info.name))
    throw std::invalid_argument("scene " + r.info.name + ": a model built in code is run under a name, not a scene "
                                "file's (.json) path; give it another name");
  if (!config.assignments.empty())
    throw std::invalid_argument("--set sets a scene's parameters: a model built in code has its parameters in the code");
  if (!(config.dt > 0.0))
    throw std::invalid_argument("--dt " + std::to_string(config.dt) +
                                ": give the step (a model built in code has no default)");
  if (config.t_end < 0.0)
    throw std::invalid_argument("--t-end: give the end time (a model built in code has no default)");
  if (config.t_end < t0) {
    std::ostringstream os;
    os.precision(17);
    os << "--t-end " << config.t_end << " is before the start's t0 = " << t0 << ": give the time the run ends at";
    throw std::invalid_argument(os.str());
  }
  r.dt = config.dt;
  check_options(config, config.t_end, r);
  return r;
}

RunSummary run_scene(const RunConfig& given) {
  const auto start_time = std::chrono::steady_clock::now();
  std::string resume = checkpoint_to_resume(given);
  RunSource source;
  const RunConfig config = resume.empty() ? given : resumed_config(given, resume, source);
  if (source.from_code)
    throw std::invalid_argument("--resume " + given.resume_path + ": the checkpoint is of a model built in code (" +
                                config.scene + "), which only its code can build again: resume it with run_model "
                                "(Python: nonholo.run(model, resume=...)) and the same model");
  PreparedRun run = prepare_run(config);
  run.resume = std::move(resume);
  Parameters params = run.info.defaults();
  for (const auto& a : config.assignments) params.assign(a);
  Progress progress(run.info.name, run.steps, config.verbosity);
  TrajectoryHooks hooks;
  hooks.progress = hooks.setup_status = &progress;
  hooks.started = start_time;
  return finished(integrate_scene(run, params, config, hooks), progress, start_time);
}

RunSummary run_model(const Model& model, const RunStart& start, const RunConfig& given) {
  const auto start_time = std::chrono::steady_clock::now();
  std::string resume = checkpoint_to_resume(given);
  RunSource source;
  const RunConfig config = resume.empty() ? given : resumed_config(given, resume, source);
  if (!resume.empty() && !source.from_code)
    throw std::invalid_argument("--resume " + given.resume_path + ": the checkpoint is of the scene " + config.scene +
                                ", not of a model built in code: resume it with run_scene (nonholo run --resume)");
  if (!resume.empty() && source.fingerprint != model_fingerprint(model)) throw wrong_model(given.resume_path);
  if (resume.empty() && start.state) check_start_state(model, *start.state);
  // A resumed run starts as the run saved did (its start is in the checkpoint), then loads its state.
  const RunStart& from = resume.empty() ? start : source.start;
  PreparedRun run = prepare_model_run(config, from.state ? from.state->t : from.t0);
  run.resume = std::move(resume);
  const Parameters none(run.info.name, {});
  Progress progress(run.info.name, run.steps, config.verbosity);
  TrajectoryHooks hooks;
  hooks.progress = hooks.setup_status = &progress;
  hooks.started = start_time;
  return finished(integrate_model(run, model, from, none, config, hooks), progress, start_time);
}

}  // namespace nonholo::scenarios
