// One trajectory as named phases (run_loop.hpp): set-up, outputs, start or resume, the loop of
// steps with the bounds each step is held to, the final checkpoint and the verdicts.
#include "run/run_loop.hpp"
#include "run/thread_choice.hpp"

#include <nonholo/scenarios/interrupt.hpp>
#include <nonholo/scenarios/scene_file.hpp>

#include <nonholo/rattle.hpp>
#include <nonholo/sparse/big_buffer.hpp>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <cstdio>
#include <limits>
#include <random>
#include <sstream>

#include "output/batch_row.hpp"
#include "output/checkpoint/checkpoint_file.hpp"
#include "output/checkpoint/model_fingerprint.hpp"
#include "output/checkpoint/run_config_archive.hpp"
#include "run/verdicts.hpp"

namespace nonholo::scenarios {
namespace {

using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

// Relative change, or absolute when the reference is zero.
// floor: rest_scales' energy, for an initial energy of 0 (or below it).
double relative_change(double value, double reference, double floor) {
  const double diff = std::abs(value - reference);
  const double scale = std::max(std::abs(reference), floor);
  return scale > 0.0 ? diff / scale : diff;
}

// The energy error net of the work done by external forces, relative to the largest of the
// initial energy, the current one and the work (the scales round-off is relative to).
double balance_error(double energy, double initial, double work, double floor) {
  const double scale = std::max({std::abs(initial), std::abs(energy), std::abs(work), floor});
  const double diff = std::abs(energy - initial - work);
  return scale > 0.0 ? diff / scale : diff;
}

RestScales rest_scales(const Model& model, double t, ConstVecRef q, double h) {
  if (!model.has_applied_force()) return {};
  const int n = model.num_velocities();
  Vector f(n), scratch(n);
  model.applied_force(t, q, f, scratch);
  model.inverse_mass().multiply(f.data(), scratch.data());
  return {0.5 * h * h * f.dot(scratch), h * scratch.lpNorm<Eigen::Infinity>()};
}

// The options with the dt and t_end the run uses (for the output files' attributes).
RunConfig resolved(const RunConfig& config, const PreparedRun& run) {
  RunConfig c = config;
  c.dt = run.dt;
  c.t_end = run.t_end;
  return c;
}

// The output files are flushed to disk at least this often (when frames come).
constexpr double kFlushSeconds = 2.0;

bool finite(const Diagnostics& d) {
  return std::isfinite(d.energy) && std::isfinite(d.residual) && std::isfinite(d.gap) &&
         !std::isinf(d.energy_post);  // energy_post is NaN where it is not defined
}

std::string describe(const Diagnostics& d) {
  std::ostringstream os;
  os << "energy " << d.energy << ", energy_post " << d.energy_post << ", residual " << d.residual << ", gap " << d.gap;
  return os.str();
}

// A fresh run's id: 64 random bits as 16 hex digits (written into its HDF5 output and checkpoints,
// so that a resume knows its own file from another run's).
std::string new_run_id() {
  std::random_device random;
  const std::uint64_t bits = (static_cast<std::uint64_t>(random()) << 32) ^ random();
  char text[17];
  std::snprintf(text, sizeof text, "%016llx", static_cast<unsigned long long>(bits));
  return text;
}

// The order the accuracy check's advice assumes.
int method_order(const RunConfig& config, const MethodChoice& choice) {
  if (config.method == "reflection") return choice.rattle.order;
  return config.method == "rk4" ? 4 : config.method == "dla-left" ? 1 : 2;
}

// Whether the output intervals capped a method's own steps: about `per_interval` steps (a pair for
// adaptive composed steps, one for ARKODE) in each of `intervals`, within a sixteenth.
bool capped_by_intervals(long internal, long intervals, long per_interval) {
  return internal <= per_interval * (intervals + intervals / 16);
}

// Why the accuracy check's companion stopped (at t; NaN: it could not start).
std::string check_failure_text(const PreparedRun& run, const std::string& why, double t) {
  std::ostringstream os;
  os.precision(6);
  os << "the accuracy check's companion (" << (run.choice.adaptive_on() ? "adaptive steps at tol " : "steps of ")
     << (run.choice.adaptive_on() ? run.check.choice.adaptive.tol : 2.0 * run.dt) << ") "
     << (std::isnan(t) ? std::string("could not start") : "failed at t = " + std::to_string(t)) << ": " << why;
  return os.str();
}

}  // namespace

void LoopState::save(OutArchive& a) const {
  a.tag("loop");
  a(k), a(t0);
  scenarios::save(a, summary);
  a(d0.energy), a(d0.energy_post), a(d0.residual), a(d0.gap), a(power0), a(power);
  work.save(a);
  a(rest.energy), a(rest.speed), a(j0), a(lever_arm), a(difference), a(companion_failure), a(output_position);
  a(static_cast<long>(output_tail)), a(run_id);  // (the hash's bits through a long)
  a(seconds);
  a(check_difference), a(check_failure), a(check_stepped);
  range.save(a);
}

void LoopState::load(InArchive& a) {
  a.tag("loop");
  a(k), a(t0);
  scenarios::load(a, summary);
  a(d0.energy), a(d0.energy_post), a(d0.residual), a(d0.gap), a(power0), a(power);
  work.load(a);
  a(rest.energy), a(rest.speed);
  a.resize_into(j0);
  a(lever_arm), a(difference), a(companion_failure), a(output_position);
  long tail = 0;
  a(tail), a(run_id);
  output_tail = static_cast<std::uint64_t>(tail);
  a(seconds);
  a(check_difference), a(check_failure), a(check_stepped);
  range.load(a);
}

RunLoop::RunLoop(const PreparedRun& run, const Model& model, const RunStart& start, const Parameters& params,
                 const RunConfig& config, const TrajectoryHooks& hooks, std::function<void()> release_start,
                 Clock::time_point started)
    : run_(run),
      model_(model),
      start_(start),
      release_start_(std::move(release_start)),
      params_(params),
      config_(config),
      hooks_(hooks),
      reflection_(config.method == "reflection"),
      run_start_(started) {}

TrajectoryResult RunLoop::run() {
  // Ctrl-C during a long set-up (a 10^7-body chain's: a minute) ends the run at the next phase,
  // before anything is written (it waited for the whole set-up and wrote the first frame).
  if (stop_signalled()) return interrupted_in_set_up();
  set_up();
  if (stop_signalled()) return interrupted_in_set_up();
  read_loop_state();
  open_outputs();
  describe_run();
  if (run_.resume.empty())
    start();
  else
    resume();
  loop();
  close_outputs();
  judge();
  return result();
}

// Models with this many coordinates and more hand set-up's freed heap back (8 MB vectors).
constexpr int kTrimFromCoordinates = 1 << 20;

// "setting up sleigh_chain (1000000 bodies): analysing C..." (bodies < 0: not known yet).
static void report_setup(const TrajectoryHooks& hooks, const std::string& name, long bodies, const char* phase) {
  if (!hooks.setup_status) return;
  std::string line = "setting up " + name;
  if (bodies > 0) line += " (" + std::to_string(bodies) + (bodies == 1 ? " body)" : " bodies)");
  hooks.setup_status->status(line + ": " + phase + "...");
}

void RunLoop::set_up() {
  if (hooks_.on_model) hooks_.on_model(model_);
  stops_ = std::make_unique<StopWatch>(model_, config_);  // a bad --stop-when is refused first
  if (stops_->empty()) stops_.reset();
  const SetupPhase phase = [this](const char* p) { report_setup(hooks_, run_.info.name, model_.num_bodies(), p); };
  // (Only where a checkpoint is written or read: it reads every name and mass.)
  if (!config_.checkpoint_path.empty() || !run_.resume.empty()) fingerprint_ = model_fingerprint(model_);
  const ThreadChoice threads = choose_threads(config_.threads, model_, reflection_, config_.hitch);
  thread_warning_ = threads.warning;
  MethodChoice choice = run_.choice;
  choice.threads = threads.threads;
  try {
    runner_ = make_runner(model_, start_, choice, phase);
  } catch (const std::invalid_argument& e) {  // a scene file's start: name the file
    if (!is_scene_file(config_.scene)) throw;
    throw std::invalid_argument(config_.scene + ": " + e.what());
  }
  team_probe_.emplace(runner_->threads(), [this](int team) { runner_->set_team(team); });
  runner_->set_stop([this] { return stop_signalled(); });
  if (config_.error_estimate) {
    MethodChoice companion = run_.companion.choice;
    companion.threads = threads.threads;
    companion_ = make_runner(model_, start_, companion, phase);
    companion_->set_stop([this] { return stop_signalled(); });
  }
  if ((check_companion_ = wants_check_companion())) {
    MethodChoice check = run_.check.choice;
    check.threads = threads.threads;
    try {
      check_ = make_runner(model_, start_, check, phase);
      check_->set_stop([this] { return stop_signalled(); });
    } catch (const std::exception& e) {  // (a step of 2 dt out of range, say): the sampled check judges
      loop_.check_failure = check_failure_text(run_, e.what(), std::numeric_limits<double>::quiet_NaN());
    }
  }
  if (!release_start_) return;
  release_start_();
  // What set-up freed inside the heap, for a model whose buffers are large (not each small
  // trajectory of a batch: the trim walks and locks every arena).
  if (model_.num_configuration() >= kTrimFromCoordinates) sparse::release_free_memory();
}

// A resumed run: the loop's state from the checkpoint (after the options, which prepare_run
// has read); the output continues where the checkpoint left it.
void RunLoop::read_loop_state() {
  if (run_.resume.empty()) return;
  archive_ = std::make_unique<InArchive>(run_.resume);
  RunConfig saved;
  load(*archive_, saved);
  RunSource source;
  load(*archive_, source);
  if (source.fingerprint != fingerprint_) throw wrong_model(config_.resume_path);
  loop_.load(*archive_);
}

// --out: CSV, or HDF5 by its extension (hdf5_output.hpp); the caller's sink gets the frames too.
// The output and the checkpoint are locked first, before a file is cut or created: a second run
// writing either is refused (file_lock.hpp).
void RunLoop::open_outputs() {
  const Model& model = model_;
  const bool resuming = archive_ != nullptr;
  const std::string& out = config_.csv_path;
  if (!out.empty() && out != "-") output_lock_ = FileLock::take(out, "output");
  if (!config_.checkpoint_path.empty()) checkpoint_lock_ = FileLock::take(config_.checkpoint_path, "checkpoint");
  // (Not for a batch's rows: they have neither.)
  if (!resuming && (!out.empty() || !config_.checkpoint_path.empty())) loop_.run_id = new_run_id();
  if (is_hdf5_path(out))
    h5_ = resuming ? std::make_unique<Hdf5RunWriter>(out, loop_.output_position, loop_.run_id)
                   : std::make_unique<Hdf5RunWriter>(out, resolved(config_, run_), run_.info.name, params_,
                                                     run_.steps, loop_.run_id);
  else if (!out.empty())
    csv_ = resuming ? std::make_unique<CsvWriter>(out, loop_.output_position, loop_.output_tail)
                    : std::make_unique<CsvWriter>(out, model.coordinate_names());
  if (!out.empty() && out != "-" && !output_lock_.held()) output_lock_ = FileLock::take(out, "output");  // made now
  for (FrameSink* s : {static_cast<FrameSink*>(h5_.get()), config_.sink})
    if (s) sinks_.push_back(s);
  for (FrameSink* s : sinks_) {
    s->velocities(model.velocity_names());
    s->begin(model.coordinate_names());
  }
}

void RunLoop::describe_run() {
  const Model& model = model_;
  const MethodChoice& choice = run_.choice;
  RunSummary& summary = summary_;
  summary.scene = run_.info.name;
  summary.method = config_.method;
  summary.backend = runner_->backend();
  summary.threads = runner_->threads();
  add_warning(summary, WarningKind::Performance, thread_warning_);
  add_warning(summary, WarningKind::Performance, model.performance_note());  // a scene file's chain out of order, a hub body
  // The reference methods treat hitch rows as velocity constraints, closed by --project.
  summary.hitch = reflection_ ? to_string(config_.hitch)
                              : !reference_method(config_.method) ? "oneform"
                              : config_.project ? "projected" : "velocity";
  summary.restart = reflection_ ? restart_spec(choice.rattle.restart) : "";
  summary.order = reflection_ ? choice.rattle.order : 0;
  if (reflection_ && choice.rattle.order > 2)
    summary.composition = to_string(composition_scheme(choice.rattle.order, choice.rattle.composition).composition);
  summary.restarts = runner_->restarts();
  if (reflection_ && model.has_rigid_bodies()) summary.rotation = to_string(choice.rattle.rotation);
  summary.parasitic_max = std::numeric_limits<double>::quiet_NaN();  // until measured
  // With external forces the energy is not an invariant: the balance against the work is. The
  // order-2 reflection step has its discrete work-energy identity (docs/design.md section 8); the
  // other methods and the composed steps (whose multipliers restart) integrate the power.
  forced_ = model.has_external_force();
  summary.has_work = forced_;
  exact_work_ = forced_ && reflection_ && choice.rattle.order == 2 && !model.has_configuration_metric();
  if (forced_) force_.resize(model.num_velocities());  // F(t, q) for the power: forced models only
  summary.bodies = model.num_bodies();
  summary.dt = run_.dt;
  summary.has_momentum = !model.momentum_maps().empty();
  j_.resize(static_cast<Eigen::Index>(model.momentum_maps().size()));
}

void RunLoop::start() {
  const Model& model = model_;
  const double dt = run_.dt;
  loop_.d0 = runner_->diagnostics();
  loop_.power0 = forced_ ? power_now() : 0.0;
  loop_.power = loop_.power0;
  loop_.work.start(loop_.power0, dt);
  loop_.rest = rest_scales(model, runner_->t(), runner_->q(), dt);
  loop_.t0 = runner_->t();
  if (check_companion_ && run_.choice.adaptive_on()) include_in_extent();
  make_watches();
  const Diagnostics& d0 = loop_.d0;
  loop_.j0.resize(static_cast<Eigen::Index>(model.momentum_maps().size()));
  runner_->momentum_maps(loop_.j0);
  summary_.residual_max = d0.residual;
  summary_.residual_rel_max = relative_residual();
  summary_.gap_max = d0.gap;
  loop_.lever_arm = hitch_lever_arm(model, runner_->q(), runner_->workspace());
  write_frame(d0);
  if (h5_) h5_->flush_to_disk();  // a valid file from the start (HDF5 writes its metadata at a flush)
  if (!finite(d0)) {
    summary_.status = Status::NonFiniteState;
    // A finite energy with a forced model: the forces overflow the half kick's energy, not the
    // state (it blamed the initial velocities for a thrust of 1e200).
    summary_.message = std::isfinite(d0.energy) && forced_
                           ? "the applied forces are out of range at the start: " + describe(d0) +
                                 ": the energy after the step's half kick of h F overflows (h |F| near 1e154 or "
                                 "above); reduce the forces, or choose units that bring them nearer 1"
                           : "the initial state is out of range: " + describe(d0) +
                                 ": check the scene's initial positions and velocities (a speed of 1e155 already "
                                 "overflows the energy)";
  }
  if (summary_.status == Status::Ok) summary_.status = stability_->check(*runner_, 0, summary_.message);
  if (summary_.status == Status::Ok)
    summary_.status = precision_->check(runner_->q(), runner_->velocity(), dt, 0, summary_.message);
  if (summary_.status == Status::Ok) stop_condition_holds(0);
}

// A stop condition that holds (after step k; 0: at the start) ends the run: the summary's
// stopped_by and t_stop now, status=stopped once the verdicts are made (judge). One that threw
// fails the run with its message.
bool RunLoop::stop_condition_holds(long k) {
  if (!stops_) return false;
  const bool held = k == 0 ? stops_->check_start(runner_->t(), runner_->q(), runner_->velocity())
                           : stops_->check(k, k == run_.steps, runner_->t(), runner_->q(), runner_->velocity());
  if (!held) return false;
  if (!stops_->failure().empty()) {
    summary_.status = Status::CallbackFailed;
    summary_.message = (k == 0 ? std::string("at the start: ") : "after step " + std::to_string(k) + ": ") +
                       stops_->failure() + "; the output holds every row up to step " + std::to_string(k);
  } else {
    summary_.stopped_by = stops_->fired();
    summary_.t_stop = stops_->t_stop();
  }
  return true;
}

// The stability and precision watches, once the rest scales are known (measured or loaded).
void RunLoop::make_watches() {
  // A velocity at round-off of the rest scale (a body at rest) satisfies no constraint to any
  // relative accuracy: its relative residual is not judged.
  speed_floor_ = 64 * std::numeric_limits<double>::epsilon() * loop_.rest.speed;
  stability_ = std::make_unique<StabilityWatch>(model_, run_.choice, run_.dt);
  precision_ = std::make_unique<PrecisionWatch>(model_, speed_floor_, run_.t_end - loop_.t0);
}

void RunLoop::resume() {
  make_watches();
  summary_ = loop_.summary;
  if (summary_.status == Status::Interrupted) {  // what a resume is for
    summary_.status = Status::Ok;
    summary_.message.clear();
  } else if (summary_.status != Status::Ok) {
    throw std::invalid_argument("--resume " + config_.resume_path + ": the run ended with status=" +
                                to_string(summary_.status) + " at step " + std::to_string(loop_.k) + " (" +
                                summary_.message + "): there is nothing to continue");
  }
  if (!summary_.stopped_by.empty()) {
    std::ostringstream os;
    os.precision(17);
    os << "--resume " << config_.resume_path << ": the run was stopped by its condition " << summary_.stopped_by
       << " at t = " << summary_.t_stop << " (step " << loop_.k << "): there is nothing to continue";
    throw std::invalid_argument(os.str());
  }
  runner_->load(*archive_);
  if (companion_) companion_->load(*archive_);
  if (check_ && loop_.check_failure.empty()) check_->load(*archive_);
  if (!loop_.check_failure.empty()) check_.reset();  // it had failed before the checkpoint
  stability_->load(*archive_);
  precision_->load(*archive_);
  bool stops = false;
  (*archive_)(stops);
  if (stops != static_cast<bool>(stops_))
    throw std::invalid_argument("--resume " + config_.resume_path + ": the run was " +
                                (stops ? "given stop conditions and this one none" : "given no stop conditions and this one some") +
                                ": give the conditions the run was given (conditions in code are not saved)");
  if (stops_) stops_->load(*archive_);
  if (!archive_->done()) throw std::runtime_error("checkpoint: bytes left over after the run's state");
}

void RunLoop::loop() {
  last_checkpoint_ = last_flush_ = Clock::now();
  if (hooks_.progress) hooks_.progress->begin_steps();
  loop_start_ = Clock::now();
  summary_.setup_s = std::chrono::duration<double>(loop_start_ - run_start_).count();
  for (long k = loop_.k + 1; k <= run_.steps && summary_.status == Status::Ok && summary_.stopped_by.empty(); ++k) {
    if (stop_requested(k) || watches_fail(k) || !advance(k)) break;
    if (config_.sink) config_.sink->progress(runner_->t(), static_cast<double>(k) / static_cast<double>(run_.steps));
    const Diagnostics d = measure(k);
    const bool stop_now = summary_.status == Status::Ok && stop_condition_holds(k);
    const bool output = stop_now || k % config_.every == 0 || k == run_.steps;
    if (companion_) companion_step(k, output);
    if (check_companion_) check_step(k);
    if (output && (csv_ || !sinks_.empty())) {
      const auto out_start = Clock::now();
      write_frame(d);
      // On disk every few seconds: a killed run keeps what was written up to the last flush.
      if ((csv_ || h5_) && std::chrono::duration<double>(out_start - last_flush_).count() >= kFlushSeconds) {
        if (csv_) csv_->flush_to_disk();
        if (h5_) h5_->flush_to_disk();
        last_flush_ = Clock::now();
      }
      output_s_ += seconds_since(out_start);
    }
    checkpoint_if_due(k);
    if (stop_now) break;
    if (hooks_.progress && (k & 15) == 0) hooks_.progress->update(k);  // it reads the clock: not every step
  }
  loop_s_ = loop_.seconds + seconds_since(loop_start_) - output_s_ - companion_s_;
}

bool RunLoop::stop_signalled() const {
  return interrupt_requested() || (config_.sink && config_.sink->stop_requested()) ||
         (config_.stop && config_.stop->load(std::memory_order_relaxed));
}

bool RunLoop::stop_requested(long k) {
  if (!stop_signalled()) return false;
  interrupted(k, false);
  return true;
}

// Who asked to stop: "interrupted (SIGINT)", or the caller (its sink or flag).
std::string RunLoop::stop_cause() const {
  return interrupt_requested() ? std::string("interrupted (") + interrupt_name() + ")" : "interrupted by the caller";
}

// Status::Interrupted and its message: after step k - 1, or during step k (an adaptive output
// interval stopped between its pairs: the state is at the last finished pair).
void RunLoop::interrupted(long k, bool during) {
  summary_.status = Status::Interrupted;
  summary_.message = stop_cause() +
                     (during ? " during step " + std::to_string(k) : " after step " + std::to_string(k - 1)) +
                     " at t = " + std::to_string(runner_->t()) + "; the output holds every row up to step " +
                     std::to_string(k - 1);
}

bool RunLoop::watches_fail(long k) {
  if (k > 1 && (summary_.status = stability_->check(*runner_, k - 1, summary_.message)) != Status::Ok) return true;
  return k > 1 && PrecisionWatch::due(k - 1) &&
         (summary_.status = precision_->check(runner_->q(), runner_->velocity(), run_.dt, k - 1,
                                              summary_.message)) != Status::Ok;
}

bool RunLoop::advance(long k) {
  const double t_before = runner_->t();
  team_probe_->before_step(k);
  const DoublingEstimate* check = runner_->accuracy();
  const bool shadow = check && check->due();  // this step also runs the check's step of 2h
  const Status status = runner_->advance(loop_.t0 + static_cast<double>(k) * run_.dt);
  if (status == Status::Ok) team_probe_->after_step(!shadow);
  if (status == Status::Interrupted) {  // between the pairs of an adaptive interval
    interrupted(k, true);
    return false;
  }
  if (status != Status::Ok) {
    summary_.status = status;
    std::ostringstream os;
    os << "step " << k << " from t = " << t_before << " failed: " << to_string(status) << ": " << runner_->message();
    summary_.message = os.str();
    return false;
  }
  summary_.steps = k;
  return true;
}

// After step k: its diagnostics against the bounds (run_checks.hpp). This step's energy errors:
// of p~ (e) and of the post-momentum (ep), net of the work when there is some. The identity:
// E_post(k-1/2) - E_post(-1/2) = sum_{j<k} h F_j^T M^-1 p~_j, exactly. The energy of p~_k sits
// half a step of work later: E(p~) = E_post(k-1/2) + (h/2) F_k^T M^-1 p~_k + O(h^2), so it is
// compared with the work to t_k, W + (h/2)(P_k - P_0). The other methods and orders: the energy
// they report against W(t_k) by Gregory's rule, whose error is below the method's own.
Diagnostics RunLoop::measure(long k) {
  RunSummary& summary = summary_;
  const Diagnostics& d0 = loop_.d0;
  const double dt = run_.dt, floor = loop_.rest.energy;
  const Diagnostics d = runner_->diagnostics();
  if (!finite(d)) {  // the step's own check passed (finite q, p), the energy or residual overflowed
    summary.status = Status::BlewUp;
    summary.message = "after step " + std::to_string(k) + " (t = " + std::to_string(runner_->t()) +
                      ") the diagnostics overflowed: " + describe(d) + ": reduce --dt";
  }
  double e, ep;
  if (exact_work_) {
    summary.work += dt * loop_.power;
    loop_.power = power_now();
    e = balance_error(d.energy, d0.energy, summary.work + 0.5 * dt * (loop_.power - loop_.power0), floor);
    ep = balance_error(d.energy_post, d0.energy_post, summary.work, floor);
    summary.energy_balance_err_max = worst(summary.energy_balance_err_max, ep);
  } else if (forced_) {
    loop_.work.add(power_now());
    summary.work = loop_.work.value();
    e = loop_.work.accurate() || k == run_.steps ? balance_error(d.energy, d0.energy, summary.work, floor) : 0.0;
    ep = std::numeric_limits<double>::quiet_NaN();
    summary.energy_balance_err_max = worst(summary.energy_balance_err_max, e);
  } else {
    e = relative_change(d.energy, d0.energy, floor);
    ep = relative_change(d.energy_post, d0.energy_post, floor);
    summary.energy_post_rel_err_max = worst(summary.energy_post_rel_err_max, ep);
  }
  summary.energy_rel_err_max = worst(summary.energy_rel_err_max, e);
  if (summary.restarts >= 0) {
    const double a = runner_->parasitic();
    if (!std::isnan(a)) summary.parasitic_max = std::isnan(summary.parasitic_max) ? a : std::max(summary.parasitic_max, a);
  }
  summary.residual_max = worst(summary.residual_max, d.residual);
  const double residual_rel = k == 1 || k % kResidualEvery == 0 || k == run_.steps ? relative_residual() : 0.0;
  summary.residual_rel_max = worst(summary.residual_rel_max, residual_rel);
  summary.gap_max = worst(summary.gap_max, d.gap);
  // Blown up: every energy measure the method has is off by more than the bound (net of the
  // work). The plain method's period-2 mode moves the energy of p~ by that much while
  // energy_post stays exact, so the smaller of the two decides.
  const double error = std::isnan(ep) ? e : std::min(e, ep);
  if (summary.status == Status::Ok && error > kEnergyBound)
    summary.status = energy_blew_up(error, forced_, k, runner_->t(), energy_advice(summary, run_.choice.rattle),
                                    summary.message);
  if (summary.status == Status::Ok)
    summary.status = check_constraints(residual_rel, d.gap, loop_.lever_arm, k, runner_->t(), summary.message);
  // The maps are sampled as the relative residual is (run_checks.hpp): they are invariants of
  // every step, so a map that moves stays moved; every step they cost 7 % of a 2 10^4-ball
  // chain's run (N + 2 maps, two of them sums over the chain).
  const bool sampled = k == 1 || k % kResidualEvery == 0 || k == run_.steps;
  if (summary.has_momentum && sampled) {
    runner_->momentum_maps(j_);
    summary.momentum_drift_max = worst(summary.momentum_drift_max, (j_ - loop_.j0).lpNorm<Eigen::Infinity>());
  }
  return d;
}

// --error-estimate: two steps of dt/2 (ARKODE: two output intervals) per step.
void RunLoop::companion_step(long k, bool output) {
  const auto companion_start = Clock::now();
  Status cs = companion_->advance(loop_.t0 + (static_cast<double>(k) - 0.5) * run_.dt);
  if (cs == Status::Ok) cs = companion_->advance(loop_.t0 + static_cast<double>(k) * run_.dt);
  if (cs == Status::Interrupted) {  // a stop request: the loop stops before its next step
  } else if (cs != Status::Ok) {
    loop_.difference = std::numeric_limits<double>::quiet_NaN();
    loop_.companion_failure = "the companion trajectory of --error-estimate failed at t = " +
                              std::to_string(companion_->t()) + ": " + companion_->message();
    companion_.reset();
  } else if (output) {
    loop_.difference = worst(loop_.difference, (runner_->q() - companion_->q()).lpNorm<Eigen::Infinity>());
  }
  companion_s_ += seconds_since(companion_start);
}

// RunConfig::accuracy_check: the companion for the methods with a check (not --error-estimate's
// runs, whose companion judges them), by default up to kCompanionMaxVelocities; for adaptive
// steps always (they have no other check, and their companion at 10 tol costs less).
bool RunLoop::wants_check_companion() const {
  if (!(config_.accuracy > 0.0) || config_.error_estimate || config_.accuracy_check == "sampled") return false;
  if (run_.choice.adaptive_on()) return true;
  if (!runner_->accuracy()) return false;  // a method without a check
  return config_.accuracy_check == "companion" || model_.num_velocities() <= kCompanionMaxVelocities;
}

// The accuracy check's companion: one step of 2 dt every two steps (adaptive steps: its own to
// every other output time and the last), compared with the run where both are.
void RunLoop::check_step(long k) {
  const bool adaptive = run_.choice.adaptive_on();
  if (adaptive) include_in_extent();
  if (!check_ || (k % run_.check.stride != 0 && !(adaptive && k == run_.steps))) return;
  const auto check_start = Clock::now();
  const Status cs = check_->advance(loop_.t0 + static_cast<double>(k) * run_.dt);
  if (cs == Status::Interrupted) {  // a stop request: the loop stops before its next step
  } else if (cs != Status::Ok) {
    const std::string why =
        check_failure_text(run_, to_string(cs) + std::string(": ") + check_->message(), check_->t());
    // Its own trajectory failed (its period-2 mode or gap iteration at 2 dt: the 200-body train at
    // t = 87, whose run is fine): started again from the run's state, the difference so far kept.
    // Failing again on its first step, a step of 2 dt fails from the run's own state: dt is
    // within a factor 2 of what the method can take, and the sampled check judges.
    if (!loop_.check_stepped || !reseed_check()) {
      loop_.check_failure = why;
      check_.reset();
    }
  } else {
    loop_.check_stepped = true;
    loop_.check_difference = worst(loop_.check_difference, (runner_->q() - check_->q()).lpNorm<Eigen::Infinity>());
  }
  companion_s_ += seconds_since(check_start);
}

// The companion made again from the run's state (its configuration and velocity, valid after
// measure()): a rare event, which allocates (a new runner) outside the steps.
bool RunLoop::reseed_check() {
  const RunStart from_run{runner_->t(), runner_->q(), runner_->velocity(), {}};
  MethodChoice choice = run_.check.choice;
  choice.threads = runner_->threads();
  try {
    check_ = make_runner(model_, from_run, choice);
    check_->set_stop([this] { return stop_signalled(); });
  } catch (const std::exception&) {
    return false;
  }
  loop_.check_stepped = false;
  return true;
}

double RunLoop::largest_coordinate() const {
  return loop_.range.size() > 0 ? loop_.range.largest_coordinate(runner_->q()) : 0.0;
}

void RunLoop::include_in_extent() {
  if (loop_.range.size() == 0) loop_.range = Extent(runner_->q().size());
  loop_.range.include(runner_->q());
}

// The companion's estimate (companion_estimate) replaces the sampled check's where it compared;
// where it failed, the sampled check judges (fixed steps), or nothing does (adaptive steps: not ok,
// judge_accuracy). The extent: the sampled check's, or (adaptive steps) the range of q.
void RunLoop::estimate_from_check() {
  RunSummary& summary = summary_;
  const bool adaptive = run_.choice.adaptive_on();
  if (adaptive && loop_.range.size() > 0) summary.extent = loop_.range.extent(runner_->q());
  if (check_ && summary.steps >= (adaptive ? 1 : 2)) {
    double ratio = run_.check.ratio;
    // Adaptive steps capped by the output intervals (about a pair per interval, as judge() warns):
    // the companion's are twice as long, its error 2^p times the run's, not 10 times.
    if (adaptive && run_.check.stride == 2 && capped_by_intervals(runner_->internal_steps(), summary.steps, 2))
      ratio = std::ldexp(1.0, method_order(config_, run_.choice));
    summary.error_estimate = companion_estimate(loop_.check_difference, ratio, config_.accuracy * summary.extent);
    // Where the sampled check saw a transient faster than the step at the start (a pair of steps
    // differing by more than 1 % of the speed, the next a hundred times quieter: an initial layer
    // the step jumps), the run and the companion both jump it, their error falls more slowly than
    // dt^p and Richardson's ratio does not hold: the sampled sum stands if larger (the inertia-1e-10
    // chain: 0.074 for 0.49; the sum 0.52). Not for every sample outside the asymptotic regime, as
    // --error-estimate does, nor for transients later in the run: on the 40 hard cases those
    // brought back 5 of the sampled check's false alarms (driven snakeboards, 20-98 times the error).
    const DoublingEstimate* w = runner_->accuracy();
    if (w && w->transient_samples() > 0 && w->first_transient() <= loop_.t0 + 8.0 * run_.dt &&
        w->estimate() > summary.error_estimate)
      summary.error_estimate = w->estimate();
    summary.accuracy_check = "companion";
    return;
  }
  summary.accuracy_check = adaptive ? "companion" : "sampled";
  if (!adaptive) {
    if (!loop_.check_failure.empty() && summary.status == Status::Ok)
      add_warning(summary, WarningKind::Accuracy, loop_.check_failure + ": the sampled check judged the run instead (it cannot see errors "
                                                 "that grow)");
    return;
  }
  // Adaptive steps have no other check: nothing judged the result, which cannot pass as ok.
  summary.error_estimate = std::numeric_limits<double>::quiet_NaN();
  if (summary.status != Status::Ok || !(config_.accuracy > 0.0)) return;
  summary.status = Status::Inaccurate;
  summary.accuracy = config_.accuracy;
  summary.message = loop_.check_failure.empty()
                        ? "the accuracy check's companion compared nothing, so nothing judged the result"
                        : loop_.check_failure + ", so nothing judged the result";
  summary.message += "; a smaller --tol may let it through. The results are written; --accuracy 0 accepts them "
                     "unjudged";
}

void RunLoop::write_frame(const Diagnostics& d) {
  if (csv_) csv_->row(runner_->t(), runner_->q(), d);
  for (FrameSink* s : sinks_) s->frame(runner_->t(), runner_->q(), runner_->p(), d);
}

void RunLoop::checkpoint_if_due(long k) {
  if (summary_.status != Status::Ok || config_.checkpoint_path.empty()) return;
  const bool due = (config_.checkpoint_every_steps > 0 && k % config_.checkpoint_every_steps == 0) ||
                   (config_.checkpoint_every_seconds > 0.0 &&
                    seconds_since(last_checkpoint_) >= config_.checkpoint_every_seconds);
  if (!due) return;
  const auto checkpoint_start = Clock::now();
  const double before = loop_.seconds;  // the integration's seconds before this process
  loop_.seconds = before + seconds_since(loop_start_) - output_s_ - companion_s_;
  write_checkpoint_now(k);
  loop_.seconds = before;
  output_s_ += seconds_since(checkpoint_start);
}

// The checkpoint: the loop's state at the end of step k, the outputs flushed first so that the
// position it records is on disk.
void RunLoop::write_checkpoint_now(long k) {
  if (csv_) {
    loop_.output_position = csv_->flush_to_disk();
    loop_.output_tail = csv_->tail_hash();
  }
  if (h5_) loop_.output_position = h5_->flush_to_disk();
  loop_.k = k;
  loop_.summary = summary_;
  OutArchive out;
  RunConfig effective = config_;
  effective.horizon = run_.choice.adaptive.horizon;
  effective.threads = runner_->threads();  // a resumed run splits the chain as this one did
  effective.resume_path.clear();
  // Absolute paths: a resume from another directory still finds the output and the scene file.
  if (!effective.csv_path.empty()) effective.csv_path = std::filesystem::absolute(effective.csv_path).string();
  if (is_scene_file(effective.scene)) effective.scene = std::filesystem::absolute(effective.scene).string();
  save(out, effective);
  save(out, run_.from_code, start_, fingerprint_);
  loop_.save(out);
  runner_->save(out);
  if (companion_) companion_->save(out);
  if (check_) check_->save(out);
  stability_->save(out);
  precision_->save(out);
  out(static_cast<bool>(stops_));
  if (stops_) stops_->save(out);
  write_checkpoint(config_.checkpoint_path, {run_.info.name, config_.method, runner_->t(), k, loop_.run_id},
                   out.bytes(), runner_->q(), runner_->p(), &checkpoint_lock_);
  last_checkpoint_ = Clock::now();
}

// The final checkpoint (the state the loop ended in, before the verdicts below, which a resumed
// run makes afresh at its own end); the error estimates; the files closed.
void RunLoop::close_outputs() {
  RunSummary& summary = summary_;
  if (!config_.checkpoint_path.empty()) {
    loop_.seconds = loop_s_;
    write_checkpoint_now(summary.steps);
  }
  summary.stability_ratio = stability_->ratio();
  if (summary.status == Status::Ok) {
    add_warning(summary, WarningKind::Stability, stability_->warning());
    add_warning(summary, WarningKind::Precision, precision_->warning());
  }
  if (const DoublingEstimate* w = summary.steps > 0 ? runner_->accuracy() : nullptr) {  // no step: nothing to judge
    summary.error_estimate = w->estimate();
    summary.extent = w->extent();
    // (a check with no sample at all is judged in judge_accuracy: not ok)
    if (w->failed_samples() > 0 && w->samples() > 0 && summary.status == Status::Ok)  // a failed run says it all
      add_warning(summary, WarningKind::Accuracy, "the accuracy check's step of 2 dt failed " + std::to_string(w->failed_samples()) +
                               " times (first at " + w->first_failure() + "): dt is within a factor 2 of what the " +
                               "method can take here; " + std::to_string(w->single_samples()) +
                               " of those samples were taken as two steps of dt/2 against one of dt instead, and " +
                               "the estimate covers the samples that worked");
  }
  if (check_companion_ && summary.steps > 0) estimate_from_check();
  else if (runner_->accuracy() && summary.steps > 0 && config_.accuracy > 0.0) summary.accuracy_check = "sampled";
  // A run without a step compared nothing: no estimate.
  summary.has_error_estimate = config_.error_estimate;
  if (config_.error_estimate) {
    const double in_run = summary.error_estimate;
    summary.error_estimate =
        summary.steps > 0 ? run_.companion.scale * loop_.difference : std::numeric_limits<double>::quiet_NaN();
    // Richardson's factor assumes the asymptotic regime; where the accuracy check saw steps outside
    // it (a step of 2 dt and two of dt differing by more than 1 % of the speed), the companion
    // understates (the inertia-1e-10 chain: 0.22 for 0.49), and the check's own sum stands.
    const DoublingEstimate* w = runner_->accuracy();
    if (w && w->fast_samples() > 0 && in_run > summary.error_estimate) summary.error_estimate = in_run;
    if (config_.accuracy > 0.0 && w) summary.accuracy_check = "error-estimate";
  }
  if (csv_) csv_->close();
  for (FrameSink* s : sinks_) s->end();
}

void RunLoop::judge() {
  RunSummary& summary = summary_;
  const MethodChoice& choice = run_.choice;
  summary.t_final = runner_->t();
  summary.rhs_evaluations = runner_->rhs_evaluations();
  if (choice.adaptive_on()) {
    summary.tol = choice.adaptive.tol;
    summary.adaptive_steps = runner_->internal_steps();
    summary.rejected = runner_->rejected();
  }
  summary.factorizations = runner_->factorizations();
  summary.threads_note = team_probe_->note();
  if (summary.restarts >= 0) summary.restarts = runner_->restarts();
  if (model_.has_rigid_bodies()) summary.legendre_iterations_max = runner_->legendre_iterations();
  if (forced_) summary.energy_post_rel_err_max = std::numeric_limits<double>::quiet_NaN();  // not an invariant
  if (summary.status == Status::Ok && summary.parasitic_max > kParasiticWarning)
    add_warning(summary, WarningKind::Method, parasitic_warning(summary, choice.rattle));
  // ARKODE stops at every output time (--dt): one step per interval means that its error
  // control wanted longer steps than --dt allowed, at the cost of evaluations.
  const long internal = runner_->internal_steps();
  if (choice.adaptive_on() && summary.steps >= 4 && capped_by_intervals(internal, summary.steps, 2))
    add_warning(summary, WarningKind::Performance, "the adaptive steps took about one pair per output interval (" + std::to_string(internal) +
                             " steps for " + std::to_string(summary.steps) +
                             " intervals): --dt, the output interval, probably capped them; a larger --dt lets "
                             "the error control choose longer steps");
  else if (!choice.adaptive_on() && internal >= 0 && summary.steps >= 4 &&
           capped_by_intervals(internal, summary.steps, 1))
    add_warning(summary, WarningKind::Performance, "ARKODE took about one step per output interval (" + std::to_string(internal) +
                             " steps for " + std::to_string(summary.steps) +
                             " intervals): --dt, its output interval, probably capped its step; a larger --dt "
                             "lets its error control choose longer steps (fewer evaluations at the same tolerance)");
  add_warning(summary, WarningKind::Accuracy, loop_.companion_failure);
  if ((runner_->accuracy() || check_companion_) && summary.steps > 0)  // after the warnings it may add to
    judge_accuracy(summary, config_, method_order(config_, choice), runner_->accuracy(), largest_coordinate(),
                   reflection_);
  summary.ns_per_step = summary.steps > 0 ? 1e9 * loop_s_ / static_cast<double>(summary.steps) : 0.0;
  summary.ns_per_body_step = summary.ns_per_step / summary.bodies;
  if (summary.status == Status::Ok && !summary.stopped_by.empty()) {
    std::ostringstream os;
    os.precision(17);
    os << "stopped by " << summary.stopped_by << ", which first held at t = " << summary.t_stop << " (step "
       << summary.steps << " at t = " << summary.t_final << " saw it; the output ends there)";
    summary.status = Status::Stopped;
    summary.message = os.str();
  }
}

TrajectoryResult RunLoop::result() {
  TrajectoryResult r;
  if (hooks_.final_q) r.final_q = runner_->q();
  if (hooks_.final_state) {
    r.final_p = runner_->p();
    r.coordinates = model_.coordinate_names();
    r.velocities = model_.velocity_names();
  }
  // The file's wall_s: all of the run but the closing itself (it was 0: set by the caller, after).
  summary_.wall_s = std::chrono::duration<double>(Clock::now() - hooks_.started.value_or(run_start_)).count();
  if (h5_) h5_->finish(summary_);  // the summary's attributes, then the file is closed
  r.summary = std::move(summary_);
  return r;
}

// A stop request during set-up: status=interrupted, no step taken and nothing written.
TrajectoryResult RunLoop::interrupted_in_set_up() {
  TrajectoryResult r;
  RunSummary& summary = r.summary;
  summary.scene = run_.info.name;
  summary.method = config_.method;
  summary.dt = run_.dt;
  summary.status = Status::Interrupted;
  summary.message = stop_cause() + " during the set-up (" +
                    (runner_ ? "after the method's start" : "after building the model") +
                    "): no step was taken and no output written";
  summary.error_estimate = std::numeric_limits<double>::quiet_NaN();  // nothing compared
  summary.setup_s = std::chrono::duration<double>(Clock::now() - run_start_).count();
  return r;
}

double RunLoop::relative_residual() {
  return runner_->velocity().lpNorm<Eigen::Infinity>() > speed_floor_ ? runner_->relative_residual() : 0.0;
}

double RunLoop::power_now() {
  return external_power(model_, runner_->t(), runner_->q(), runner_->velocity(), force_);
}

TrajectoryResult integrate_model(const PreparedRun& run, const Model& model, const RunStart& start,
                                 const Parameters& params, const RunConfig& config, const TrajectoryHooks& hooks,
                                 const std::function<void()>& release_start) {
  return RunLoop(run, model, start, params, config, hooks, release_start, Clock::now()).run();
}

// "setting up sleigh_chain (1000000 bodies): building model...": the body count from the
// parameters until the model says.
TrajectoryResult integrate_scene(const PreparedRun& run, const Parameters& params, const RunConfig& config,
                                 const TrajectoryHooks& hooks) {
  const auto started = Clock::now();
  long bodies = -1;
  for (const auto& spec : params.specs())
    if (spec.name == "bodies") bodies = std::lround(params["bodies"]);
  report_setup(hooks, run.info.name, bodies, "building model");
  SceneSetup setup = run.info.build(params);
  RunStart start{setup.t0, std::move(setup.q0), std::move(setup.v0), {}};
  // The methods have made their starts from q0 and v0: nothing reads them again.
  auto release = [&start] { start = RunStart{}; };
  return RunLoop(run, setup.model, start, params, config, hooks, release, started).run();
}

}  // namespace nonholo::scenarios
