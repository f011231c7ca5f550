#include <nonholo/scenarios/run.hpp>

#include <nonholo/scenarios/scene_file.hpp>

#include "batch_row.hpp"
#include "checkpoint/checkpoint_file.hpp"
#include "checkpoint/run_config_archive.hpp"
#include "hdf5_output.hpp"
#include "interrupt.hpp"
#include "progress.hpp"
#include "run_checks.hpp"
#include "run_internal.hpp"
#include "runners.hpp"
#include "stability_watch.hpp"

#include <nonholo/diagnostics.hpp>
#include <nonholo/rattle.hpp>
#include <nonholo/start.hpp>

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <limits>
#include <memory>
#include <sstream>
#include <stdexcept>
#include <vector>

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

// The scales of a body at rest (initial energy 0: a disk standing under gravity, where the
// errors compared round-off with round-off and read 1): the kinetic energy one step of the applied
// force f(t0, q0) gives from rest, (1/2)|h f|^2_{M^-1}, and the speed, |h M^-1 f|_inf. Round-off
// in the work, the energy and the velocity is eps times these; a moving body is far above them.
struct RestScales {
  double energy = 0.0, speed = 0.0;
};
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
  long output_position = 0;  // CSV: bytes written; HDF5: frames
  double seconds = 0.0;      // integration time so far (ns_per_step of a resumed run)

  void save(OutArchive& a) const {
    a.tag("loop");
    a(k), a(t0);
    scenarios::save(a, summary);
    a(d0.energy), a(d0.energy_post), a(d0.residual), a(d0.gap), a(power0), a(power);
    work.save(a);
    a(rest.energy), a(rest.speed), a(j0), a(lever_arm), a(difference), a(companion_failure), a(output_position);
    a(seconds);
  }
  void load(InArchive& a) {
    a.tag("loop");
    a(k), a(t0);
    scenarios::load(a, summary);
    a(d0.energy), a(d0.energy_post), a(d0.residual), a(d0.gap), a(power0), a(power);
    work.load(a);
    a(rest.energy), a(rest.speed);
    a.resize_into(j0);
    a(lever_arm), a(difference), a(companion_failure), a(output_position);
    a(seconds);
  }
};

// CSV rows with shortest round-trip formatting, so no digit of the state is lost. A row is
// formatted into a fixed buffer and written whenever that fills (a row of a million-body chain
// has three million numbers: no buffer of its size).
class CsvWriter {
 public:
  CsvWriter(const std::string& path, const std::vector<std::string>& coordinates)
      : path_(path == "-" ? "standard output" : path), stdout_(path == "-") {
    file_ = stdout_ ? stdout : std::fopen(path.c_str(), "w");
    if (!file_)
      throw std::invalid_argument("cannot open '" + path + "' for writing: " + std::strerror(errno));
    std::string header = "t";
    for (const auto& c : coordinates) {
      if (header.size() > kBuffer) {  // in pieces, as the rows
        write(header.data(), header.size());
        header.clear();
      }
      header.append(1, ',').append(c);
    }
    header += ",energy,energy_post,residual\n";
    write(header.data(), header.size());
  }
  // Continues the CSV of a run resumed from a checkpoint that had written `bytes` bytes of it:
  // what follows them (rows written after the checkpoint) is dropped.
  CsvWriter(const std::string& path, long bytes) : path_(path), written_(bytes) {
    file_ = std::fopen(path.c_str(), "r+b");
    if (!file_)
      throw std::invalid_argument("cannot continue '" + path + "': cannot open it for writing: " + std::strerror(errno));
    std::fseek(file_, 0, SEEK_END);
    const long size = std::ftell(file_);
    if (size < bytes || ::ftruncate(::fileno(file_), bytes) != 0 || std::fseek(file_, bytes, SEEK_SET) != 0)
      throw std::invalid_argument("cannot continue '" + path + "': it holds " + std::to_string(size) +
                                  " bytes where the checkpoint wrote " + std::to_string(bytes) +
                                  ": not the output of this run");
  }
  ~CsvWriter() {
    if (file_ && !stdout_) std::fclose(file_);
  }
  // Writes what is buffered to the file and flushes it (a checkpoint's moment): the bytes so far.
  long flush_to_disk() {
    if (std::fflush(file_) != 0 || (!stdout_ && ::fsync(::fileno(file_)) != 0))
      throw std::runtime_error("error writing '" + path_ + "': " + std::strerror(errno));
    return written_;
  }
  void row(double t, ConstVecRef q, const Diagnostics& d) {
    char* p = buffer_;
    put(p, t);
    for (Eigen::Index i = 0; i < q.size(); ++i) put(p, q[i]);
    put(p, d.energy);
    put(p, d.energy_post);
    put(p, d.residual);
    p[-1] = '\n';
    write(buffer_, static_cast<std::size_t>(p - buffer_));
  }
  // Flushes and reports a write error (disk full, ...) as an exception.
  void close() {
    const bool bad = std::ferror(file_) != 0;
    const int rc = stdout_ ? std::fflush(file_) : std::fclose(file_);
    file_ = nullptr;
    if (bad || rc != 0) throw std::runtime_error("error writing '" + path_ + "': " + std::strerror(errno));
  }

 private:
  // A double takes at most 24 characters with to_chars; 32 leaves room for the comma.
  static constexpr std::size_t kField = 32, kBuffer = 1 << 16;
  void write(const char* data, std::size_t size) {
    std::fwrite(data, 1, size, file_);
    written_ += static_cast<long>(size);
  }
  void put(char*& p, double v) {
    if (p + kField > buffer_ + sizeof buffer_) {  // full: write what is there (never the whole row)
      write(buffer_, static_cast<std::size_t>(p - buffer_));
      p = buffer_;
    }
    p = std::to_chars(p, p + kField, v).ptr;
    *p++ = ',';
  }
  std::string path_;
  bool stdout_ = false;  // --out -
  long written_ = 0;  // bytes handed to the file
  std::FILE* file_ = nullptr;
  char buffer_[kBuffer];
};

// The energy error net of the work done by external forces, relative to the largest of the
// initial energy, the current one and the work (the scales round-off is relative to).
double balance_error(double energy, double initial, double work, double floor) {
  const double scale = std::max({std::abs(initial), std::abs(energy), std::abs(work), floor});
  const double diff = std::abs(energy - initial - work);
  return scale > 0.0 ? diff / scale : diff;
}

// The output files are flushed to disk at least this often (when frames come).
constexpr double kFlushSeconds = 2.0;

// A run takes at most this many steps (prepare_run).
constexpr double kMaxSteps = 1e12;

bool finite(const Diagnostics& d) {
  return std::isfinite(d.energy) && std::isfinite(d.residual) && std::isfinite(d.gap) &&
         !std::isinf(d.energy_post);  // energy_post is NaN where it is not defined
}

std::string describe(const Diagnostics& d) {
  std::ostringstream os;
  os << "energy " << d.energy << ", energy_post " << d.energy_post << ", residual " << d.residual << ", gap " << d.gap;
  return os.str();
}

// The accuracy check samples a pair of steps at least this often (nonholo/accuracy.hpp): about
// 2/64 = 3 % of a run's cost once the samples agree (a shadow step of 2h and a factorisation).
constexpr int kAccuracyEvery = 64;

// The accuracy check's verdict on a run that ended ok: status=inaccurate when the estimated error
// exceeds the tolerance, a fraction of the motion's extent. The advice: the step that would meet
// the tolerance if the error falls as dt^p, with a factor 2 to spare.
void judge_accuracy(RunSummary& summary, const RunConfig& config, int order, const DoublingEstimate& watch,
                    bool has_orders) {
  const double largest_coordinate = watch.largest_coordinate();
  if (summary.status != Status::Ok || !(config.accuracy > 0.0) || std::isnan(summary.extent)) return;
  summary.accuracy = config.accuracy;
  // Step doubling needs the step of 2 dt to be stable: from half the stability limit on, the
  // shadow's error is that of an unstable step, not a measure of the run's (a stiff spring chain
  // at 0.965 of the limit: estimate 11 where the error is 0.003). The stability warning says
  // what to do there.
  if (summary.stability_ratio >= 0.5) return;
  // A motion with no extent (a body at rest) is judged against round-off instead.
  const double allowed = std::max(config.accuracy * summary.extent,
                                  64 * std::numeric_limits<double>::epsilon() * largest_coordinate);
  const double e = summary.error_estimate;
  if (!(e > allowed) && !std::isnan(e)) return;
  std::ostringstream os;
  os.precision(3);
  summary.status = Status::Inaccurate;
  os << "the estimated error in q, " << e << ", is " << e / summary.extent << " of the motion's extent "
     << summary.extent << " (the widest range a coordinate swept), above --accuracy " << config.accuracy << ": ";
  const double suggested = summary.dt * 0.5 * std::pow(allowed / e, 1.0 / order);
  if (watch.transient_samples() > 0)
    os << "the step does not resolve a transient (from t = " << watch.first_transient()
       << ", a step of 2 dt and two of dt differ by more than 1 % of the speed): its error falls more slowly than "
          "dt^"
       << order << "; reduce --dt tenfold or more and compare error_estimate";
  else if (std::isfinite(suggested) && suggested > 0.0)
    os << "the step is too large for this motion; use --dt " << suggested << " or smaller (an order-" << order
       << " method's error falls as dt^" << order << ")" << (has_orders ? ", or a higher --order" : "");
  else
    os << "the step is too large for this motion: reduce --dt";
  os << ". The results are written; --accuracy 0 turns the check off";
  summary.message = os.str();
}

// A parasitic amplitude above this is worth a warning: the mode then holds its square, a
// visible share of the kinetic energy, and the trajectory is no longer the method's
// second-order approximation.
constexpr double kParasiticWarning = 1e-3;
// Gap-correction kicks (2 gap / dt) above this fraction of the motion's speed excite the mode
// beyond kParasiticWarning (the 1000-body train: kicks of 1.6e-3 of its speed gave 0.011).
constexpr double kGapKick = 1e-4;

std::string parasitic_warning(const RunSummary& r, const RattleOptions& o) {
  std::ostringstream os;
  os.precision(3);
  os << "the period-2 mode reached " << r.parasitic_max << " of the momentum (parasitic_max): the velocities and "
     << "the trajectory are off by about that much. ";
  // Above 1 despite the restarts, the continuous multiplier lambda_s(p~), quadratic in the
  // velocity, kicks the momentum by more than itself in half a step: a speed or turn rate beyond
  // what the step can follow (a sleigh at v0 = 1e4 damps its turn at 1900/s; at h = 0.01 the
  // discrete turn reached 8000 rad/s). Without restarts the mode itself grows that far.
  if (r.parasitic_max >= 1.0 && o.restart.mode == RestartMode::Auto) {
    os << "Above 1 the step cannot follow the motion: the constraint force that p~'s velocity needs turns the "
       << "momentum by more than a radian per step (a speed or a turn rate h|omega| too large for dt = " << o.h
       << "); use --dt " << o.h * std::cbrt(kParasiticWarning / (2.0 * r.parasitic_max))
       << " or smaller (the mode's seed falls as dt^3).";
    return os.str();
  }
  // Holonomic hitches close each gap within one step: a gap of g (round-off of |q| once the
  // step is tiny) becomes a velocity kick 2 g / dt, which seeds the mode no smaller step removes.
  const double speed = r.extent / (static_cast<double>(r.steps) * r.dt);  // the motion's scale
  const double kick = 2.0 * r.gap_max / r.dt;
  if (r.hitch == "holonomic" && speed > 0.0 && std::isfinite(speed) && kick > kGapKick * speed) {
    os << "The hitches' gap corrections dominate: closing gaps of up to " << r.gap_max << " (gap_max, round-off "
       << "of the coordinates) within one step of dt = " << r.dt << " kicks the velocities by up to " << kick
       << " against a motion of about " << speed << " per unit time; use --hitch oneform, or --dt "
       << 2.0 * r.gap_max / (kGapKick * speed) << " or larger.";
    return os.str();
  }
  if (o.restart.mode != RestartMode::Auto)
    os << "Use --restart auto (energy-exact restarts when needed).";
  else
    os << "Steps excite the mode faster than the restarts remove it (" << r.restarts << " restarts in " << r.steps
       << " steps, tolerance " << o.restart.tolerance_for(o.h)
       << "): the step is too large for the motion: reduce --dt (the mode's seed falls as dt^3).";
  return os.str();
}

// What to change when the energy blew up: a grown period-2 mode needs restarts (a smaller step
// does not help it), anything else a smaller step.
std::string energy_advice(const RunSummary& r, const RattleOptions& o) {
  return r.parasitic_max > kParasiticWarning ? parasitic_warning(r, o) : "reduce --dt";
}

bool reference_method(const std::string& name) {
  return name == "rk4" || name == "arkode-dp5" || name == "arkode-verner" || name == "arkode-fehlberg8";
}

}  // namespace

std::vector<SummaryField> RunSummary::fields() const {
  std::vector<SummaryField> f;
  auto text = [&f](const char* key, const std::string& value) { f.push_back({key, SummaryField::Text, 0.0, 0, value}); };
  auto number = [&f](const char* key, double value) { f.push_back({key, SummaryField::Number, value, 0, {}}); };
  auto integer = [&f](const char* key, long value) { f.push_back({key, SummaryField::Integer, 0.0, value, {}}); };
  text("scene", scene);
  text("method", method);
  text("hitch", hitch);
  if (order > 0) integer("order", order);
  if (!composition.empty()) text("composition", composition);
  if (!rotation.empty()) text("rotation", rotation);
  if (!restart.empty()) text("restart", restart);
  integer("bodies", bodies);
  integer("steps", steps);
  number("dt", dt);
  number("t_end", t_final);
  number("wall_s", wall_s);
  number("ns_per_step", ns_per_step);
  number("ns_per_body_step", ns_per_body_step);
  number("energy_rel_err_max", energy_rel_err_max);
  if (has_work) {
    number("energy_balance_err_max", energy_balance_err_max);
    if (!std::isnan(work)) number("work", work);
  } else {
    number("energy_post_rel_err_max", energy_post_rel_err_max);
  }
  number("residual_max", residual_max);
  number("residual_rel_max", residual_rel_max);
  number("gap_max", gap_max);
  if (restarts >= 0) {
    integer("restarts", restarts);
    number("parasitic_max", parasitic_max);
  }
  if (has_momentum) number("momentum_drift_max", momentum_drift_max);
  if (legendre_iterations_max >= 0) integer("legendre_iterations_max", legendre_iterations_max);
  if (adaptive_steps >= 0) {
    number("tol", tol);
    integer("adaptive_steps", adaptive_steps);
    integer("rejected", rejected);
  }
  if (rhs_evaluations >= 0) integer("rhs_evals", rhs_evaluations);
  if (factorizations >= 0) integer("factorizations", factorizations);
  if (has_error_estimate || !std::isnan(error_estimate)) number("error_estimate", error_estimate);
  if (!std::isnan(extent)) number("extent", extent);
  if (!std::isnan(stability_ratio)) number("stability_ratio", stability_ratio);
  text("backend", backend);
  text("status", to_string(status));
  return f;
}

std::string RunSummary::line() const {
  std::ostringstream os;
  os.precision(6);
  const char* separator = "";
  for (const SummaryField& field : fields()) {
    os << separator << field.key << '=';
    separator = " ";
    if (field.kind == SummaryField::Number)
      os << field.number;
    else if (field.kind == SummaryField::Integer)
      os << field.integer;
    else
      os << field.text;
  }
  return os.str();
}

PreparedRun prepare_run(const RunConfig& config) {
  PreparedRun r;
  r.info = is_scene_file(config.scene) ? load_scene_file(config.scene) : find_scene(config.scene);
  const SceneInfo& info = r.info;
  if (is_scene_file(config.scene) && !config.assignments.empty())
    throw std::invalid_argument("--set does not apply to a scene file (" + config.scene + "): edit the file");
  r.dt = config.dt > 0.0 ? config.dt : info.default_dt;
  const double t_end = config.t_end >= 0.0 ? config.t_end : info.default_t_end;
  r.choice.method = config.method;
  r.choice.backend = config.backend;
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
  if (!std::isfinite(t_end)) throw std::invalid_argument("t_end must be finite");
  if (config.every < 1)
    throw std::invalid_argument("--every " + std::to_string(config.every) + ": must be at least 1");
  // Whole steps of size dt; the run ends at the first multiple of dt at or after t_end.
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
  if (config.error_estimate) r.companion = companion_of(r.choice);
  if (!(config.accuracy >= 0.0) || !std::isfinite(config.accuracy))
    throw std::invalid_argument("--accuracy " + std::to_string(config.accuracy) +
                                ": must be a fraction of the motion's extent, at least 0 (0: off)");
  r.choice.accuracy_every = config.accuracy > 0.0 ? kAccuracyEvery : 0;
  if (!config.csv_path.empty() && !is_hdf5_path(config.csv_path) && config.csv_path != "-" &&
      !(config.csv_path.size() > 4 && config.csv_path.compare(config.csv_path.size() - 4, 4, ".csv") == 0))
    throw std::invalid_argument("--out " + config.csv_path +
                                ": name the file .csv (text) or .h5 / .hdf5 (HDF5), or give - for CSV on standard output");
  if (!config.checkpoint_path.empty() && config.csv_path == "-")
    throw std::invalid_argument("--checkpoint with --out -: a resumed run cannot continue standard output; write to a file");
  if (!config.checkpoint_path.empty() && config.method.rfind("arkode", 0) == 0)
    throw std::invalid_argument("--checkpoint: " + config.method +
                                ": ARKODE keeps its step-size controller's history inside SUNDIALS, which cannot save "
                                "it, so a resumed run would not be the same trajectory (checkpoints work for "
                                "reflection, dla-* and rk4)");
  if (config.adaptive) {
    if (config.method != "reflection")
      throw std::invalid_argument("adaptive steps are the reflection method's (method " + config.method + ")");
    r.choice.adaptive.tol = config.tol;
    // Order 2 restarts lambda~ at every step (adaptive.hpp): say so in the summary.
    if (config.order == 2) set_restart(r.choice.rattle.restart, "1");
    r.choice.adaptive.horizon = config.horizon > 0.0 ? config.horizon : t_end;  // the scenes start at t = 0
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
  return r;
}

RunSummary integrate_scene(const PreparedRun& run, const Parameters& params, const RunConfig& config,
                           Progress* progress, Vector* final_q, Progress* setup_status,
                           std::vector<std::string>* leading_names, FinalState* final_state) {
  const SceneInfo& info = run.info;
  const MethodChoice& choice = run.choice;
  const double dt = run.dt;
  const long steps = run.steps;
  const bool reflection = config.method == "reflection";

  // "setting up sleigh_chain (1000000 bodies): building model...": the body count from the
  // parameters until the model says.
  long bodies = -1;
  for (const auto& spec : params.specs())
    if (spec.name == "bodies") bodies = std::lround(params["bodies"]);
  auto set_up = [&](const char* phase) {
    if (!setup_status) return;
    std::string line = "setting up " + info.name;
    if (bodies > 0) line += " (" + std::to_string(bodies) + (bodies == 1 ? " body)" : " bodies)");
    setup_status->status(line + ": " + phase + "...");
  };
  set_up("building model");
  SceneSetup setup = info.build(params);
  const Model& model = setup.model;
  bodies = model.num_bodies();
  if (leading_names) {
    const auto& names = model.coordinate_names();
    leading_names->assign(names.begin(), names.begin() + std::min<std::size_t>(3, names.size()));
  }
  const SetupPhase phase = [&](const char* what) { set_up(what); };
  std::unique_ptr<Runner> runner;
  try {
    runner = make_runner(setup, choice, phase);
  } catch (const std::invalid_argument& e) {  // a scene file's start: name the file
    if (!is_scene_file(config.scene)) throw;
    throw std::invalid_argument(config.scene + ": " + e.what());
  }
  std::unique_ptr<Runner> companion = config.error_estimate ? make_runner(setup, run.companion.choice, phase) : nullptr;
  double companion_s = 0.0;

  // A resumed run: the loop's state from the checkpoint (after the options, which prepare_run
  // has read); the output continues where the checkpoint left it.
  const bool resuming = !run.resume.empty();
  LoopState loop;
  std::unique_ptr<InArchive> archive;
  if (resuming) {
    archive = std::make_unique<InArchive>(run.resume);
    RunConfig saved;
    load(*archive, saved);
    loop.load(*archive);
  }

  // --out: CSV, or HDF5 by its extension (hdf5_output.hpp); the caller's sink gets the frames too.
  std::unique_ptr<CsvWriter> csv;
  std::unique_ptr<Hdf5RunWriter> h5;
  if (is_hdf5_path(config.csv_path))
    h5 = resuming ? std::make_unique<Hdf5RunWriter>(config.csv_path, loop.output_position)
                  : std::make_unique<Hdf5RunWriter>(config.csv_path, resolved(config, run), info.name, params, steps);
  else if (!config.csv_path.empty())
    csv = resuming ? std::make_unique<CsvWriter>(config.csv_path, loop.output_position)
                   : std::make_unique<CsvWriter>(config.csv_path, model.coordinate_names());
  std::vector<FrameSink*> sinks;
  for (FrameSink* s : {static_cast<FrameSink*>(h5.get()), config.sink})
    if (s) sinks.push_back(s);
  FrameSink* const sink = config.sink;  // also polled for a stop
  for (FrameSink* s : sinks) {
    s->velocities(model.velocity_names());
    s->begin(model.coordinate_names());
  }

  RunSummary summary;
  summary.scene = info.name;
  summary.method = config.method;
  summary.backend = runner->backend();
  // The reference methods treat hitch rows as velocity constraints, closed by --project.
  summary.hitch = reflection ? to_string(config.hitch)
                             : !reference_method(config.method) ? "oneform"
                             : config.project ? "projected" : "velocity";
  summary.restart = reflection ? restart_spec(choice.rattle.restart) : "";
  summary.order = reflection ? choice.rattle.order : 0;
  if (reflection && choice.rattle.order > 2)
    summary.composition = to_string(composition_scheme(choice.rattle.order, choice.rattle.composition).composition);
  summary.restarts = runner->restarts();
  if (reflection && model.has_rigid_bodies()) summary.rotation = to_string(choice.rattle.rotation);
  summary.parasitic_max = std::numeric_limits<double>::quiet_NaN();  // until measured
  // With external forces the energy is not an invariant: the balance against the work is. The
  // order-2 reflection step has its discrete work-energy identity (docs/design.md section 8); the
  // other methods and the composed steps (whose multipliers restart) integrate the power.
  const bool forced = model.has_external_force();
  summary.has_work = forced;
  const bool exact_work = forced && reflection && choice.rattle.order == 2 && !model.has_configuration_metric();
  Vector force(model.num_velocities());
  auto power_now = [&] { return external_power(model, runner->t(), runner->q(), runner->velocity(), force); };
  summary.bodies = model.num_bodies();
  summary.dt = dt;
  summary.has_momentum = !model.momentum_maps().empty();

  Diagnostics& d0 = loop.d0;
  WorkIntegral& work = loop.work;
  Vector& j0 = loop.j0;
  if (!resuming) {
    d0 = runner->diagnostics();
    loop.power0 = forced ? power_now() : 0.0;
    loop.power = loop.power0;
    work.start(loop.power0, dt);
    loop.rest = rest_scales(model, runner->t(), runner->q(), dt);
    loop.t0 = runner->t();
  }
  const double power0 = loop.power0;
  double& power = loop.power;
  const RestScales rest = loop.rest;
  const double floor = rest.energy;
  // A velocity at round-off of the rest scale (a body at rest) satisfies no constraint to any
  // relative accuracy: its relative residual is not judged.
  const double speed_floor = 64 * std::numeric_limits<double>::epsilon() * rest.speed;
  auto relative_residual = [&] {
    return runner->velocity().lpNorm<Eigen::Infinity>() > speed_floor
               ? runner->relative_residual()
               : 0.0;
  };
  Vector j(model.momentum_maps().size());
  StabilityWatch stability(model, choice, dt);
  PrecisionWatch precision(model, speed_floor);
  if (!resuming) {
    j0.resize(static_cast<Eigen::Index>(model.momentum_maps().size()));
    runner->momentum_maps(j0);
    summary.residual_max = d0.residual;
    summary.residual_rel_max = relative_residual();
    summary.gap_max = d0.gap;
    loop.lever_arm = hitch_lever_arm(model, runner->q(), runner->workspace());
    if (csv) csv->row(runner->t(), runner->q(), d0);
    for (FrameSink* s : sinks) s->frame(runner->t(), runner->q(), runner->p(), d0);
    if (h5) h5->flush_to_disk();  // a valid file from the start (HDF5 writes its metadata at a flush)
    if (!finite(d0)) {
      summary.status = Status::NonFiniteState;
      summary.message = "the initial state is out of range: " + describe(d0) +
                        ": check the scene's initial positions and velocities (a speed of 1e155 already "
                        "overflows the energy)";
    }
    if (summary.status == Status::Ok) summary.status = stability.check(*runner, 0, summary.message);
    if (summary.status == Status::Ok) summary.status = precision.check(runner->q(), runner->velocity(), dt, 0, summary.message);
  } else {
    summary = loop.summary;
    if (summary.status == Status::Interrupted) {  // what a resume is for
      summary.status = Status::Ok;
      summary.message.clear();
    } else if (summary.status != Status::Ok) {
      throw std::invalid_argument("--resume " + config.resume_path + ": the run ended with status=" +
                                  to_string(summary.status) + " at step " + std::to_string(loop.k) + " (" +
                                  summary.message + "): there is nothing to continue");
    }
    runner->load(*archive);
    if (companion) companion->load(*archive);
    stability.load(*archive);
    precision.load(*archive);
    if (!archive->done()) throw std::runtime_error("checkpoint: bytes left over after the run's state");
  }
  const double lever_arm = loop.lever_arm;
  double& difference = loop.difference;
  std::string& companion_failure = loop.companion_failure;
  // The checkpoint: the loop's state at the end of step k, the outputs flushed first so that the
  // position it records is on disk.
  auto last_checkpoint = Clock::now(), last_flush = Clock::now();
  auto write_checkpoint_now = [&](long k) {
    if (csv) loop.output_position = csv->flush_to_disk();
    if (h5) loop.output_position = h5->flush_to_disk();
    loop.k = k;
    loop.summary = summary;
    OutArchive out;
    RunConfig effective = config;
    effective.horizon = choice.adaptive.horizon;
    effective.resume_path.clear();
    // Absolute paths: a resume from another directory still finds the output and the scene file.
    if (!effective.csv_path.empty()) effective.csv_path = std::filesystem::absolute(effective.csv_path).string();
    if (is_scene_file(effective.scene)) effective.scene = std::filesystem::absolute(effective.scene).string();
    save(out, effective);
    loop.save(out);
    runner->save(out);
    if (companion) companion->save(out);
    stability.save(out);
    precision.save(out);
    write_checkpoint(config.checkpoint_path, {info.name, config.method, runner->t(), k}, out.bytes(), runner->q(),
                     runner->p());
    last_checkpoint = Clock::now();
  };
  auto checkpoint_due = [&](long k) {
    if (config.checkpoint_path.empty()) return false;
    if (config.checkpoint_every_steps > 0 && k % config.checkpoint_every_steps == 0) return true;
    return config.checkpoint_every_seconds > 0.0 && seconds_since(last_checkpoint) >= config.checkpoint_every_seconds;
  };

  double output_s = 0.0;
  const double t0 = loop.t0;
  if (progress) progress->begin_steps();
  const auto loop_start = Clock::now();
  for (long k = loop.k + 1; k <= steps && summary.status == Status::Ok; ++k) {
    const double t_before = runner->t();
    const bool ctrl_c = interrupt_requested();
    if (ctrl_c || (sink && sink->stop_requested()) || (config.stop && config.stop->load(std::memory_order_relaxed))) {
      summary.status = Status::Interrupted;
      summary.message = (ctrl_c ? std::string("interrupted (") + interrupt_name() + ")" : std::string("interrupted by the caller")) + " after step " +
                        std::to_string(k - 1) + " at t = " + std::to_string(t_before) +
                        "; the output holds every row up to there";
      break;
    }
    if (k > 1 && (summary.status = stability.check(*runner, k - 1, summary.message)) != Status::Ok) break;
    if (k > 1 && PrecisionWatch::due(k - 1) &&
        (summary.status = precision.check(runner->q(), runner->velocity(), dt, k - 1, summary.message)) != Status::Ok)
      break;
    const Status status = runner->advance(t0 + static_cast<double>(k) * dt);
    if (status != Status::Ok) {
      summary.status = status;
      std::ostringstream os;
      os << "step " << k << " from t = " << t_before << " failed: " << to_string(status) << ": "
         << runner->message();
      summary.message = os.str();
      break;
    }
    summary.steps = k;
    const Diagnostics d = runner->diagnostics();
    if (!finite(d)) {  // the step's own check passed (finite q, p), the energy or residual overflowed
      summary.status = Status::BlewUp;
      summary.message = "after step " + std::to_string(k) + " (t = " + std::to_string(runner->t()) +
                        ") the diagnostics overflowed: " + describe(d) + ": reduce --dt";
    }
    // This step's energy errors: of p~ (e) and of the post-momentum (ep), net of the work when
    // there is some. The identity: E_post(k-1/2) - E_post(-1/2) = sum_{j<k} h F_j^T M^-1 p~_j,
    // exactly. The energy of p~_k sits half a step of work later: E(p~) = E_post(k-1/2) +
    // (h/2) F_k^T M^-1 p~_k + O(h^2), so it is compared with the work to t_k, W + (h/2)(P_k - P_0).
    // The other methods and orders: the energy they report against W(t_k) by Gregory's rule,
    // whose error is below the method's own (run_checks.hpp).
    double e, ep;
    if (exact_work) {
      summary.work += dt * power;
      power = power_now();
      e = balance_error(d.energy, d0.energy, summary.work + 0.5 * dt * (power - power0), floor);
      ep = balance_error(d.energy_post, d0.energy_post, summary.work, floor);
      summary.energy_balance_err_max = worst(summary.energy_balance_err_max, ep);
    } else if (forced) {
      work.add(power_now());
      summary.work = work.value();
      e = work.accurate() || k == steps ? balance_error(d.energy, d0.energy, summary.work, floor) : 0.0;
      ep = std::numeric_limits<double>::quiet_NaN();
      summary.energy_balance_err_max = worst(summary.energy_balance_err_max, e);
    } else {
      e = relative_change(d.energy, d0.energy, floor);
      ep = relative_change(d.energy_post, d0.energy_post, floor);
      summary.energy_post_rel_err_max = worst(summary.energy_post_rel_err_max, ep);
    }
    summary.energy_rel_err_max = worst(summary.energy_rel_err_max, e);
    if (summary.restarts >= 0) {
      const double a = runner->parasitic();
      if (!std::isnan(a)) summary.parasitic_max = std::isnan(summary.parasitic_max) ? a : std::max(summary.parasitic_max, a);
    }
    summary.residual_max = worst(summary.residual_max, d.residual);
    const double residual_rel = k == 1 || k % kResidualEvery == 0 || k == steps ? relative_residual() : 0.0;
    summary.residual_rel_max = worst(summary.residual_rel_max, residual_rel);
    summary.gap_max = worst(summary.gap_max, d.gap);
    // Blown up: every energy measure the method has is off by more than the bound (net of the
    // work). The plain method's period-2 mode moves the energy of p~ by that much while
    // energy_post stays exact, so the smaller of the two decides.
    const double error = std::isnan(ep) ? e : std::min(e, ep);
    if (summary.status == Status::Ok && error > kEnergyBound)
      summary.status = energy_blew_up(error, forced, k, runner->t(), energy_advice(summary, choice.rattle), summary.message);
    if (summary.status == Status::Ok)
      summary.status = check_constraints(residual_rel, d.gap, lever_arm, k, runner->t(), summary.message);
    if (summary.has_momentum) {
      runner->momentum_maps(j);
      summary.momentum_drift_max = worst(summary.momentum_drift_max, (j - j0).lpNorm<Eigen::Infinity>());
    }
    const bool output = k % config.every == 0 || k == steps;
    if (companion) {  // two steps of dt/2 (ARKODE: two output intervals) per step
      const auto companion_start = Clock::now();
      Status cs = companion->advance(t0 + (static_cast<double>(k) - 0.5) * dt);
      if (cs == Status::Ok) cs = companion->advance(t0 + static_cast<double>(k) * dt);
      if (cs != Status::Ok) {
        difference = std::numeric_limits<double>::quiet_NaN();
        companion_failure = "the companion trajectory of --error-estimate failed at t = " +
                            std::to_string(companion->t()) + ": " + companion->message();
        companion.reset();
      } else if (output) {
        difference = worst(difference, (runner->q() - companion->q()).lpNorm<Eigen::Infinity>());
      }
      companion_s += seconds_since(companion_start);
    }
    if ((csv || !sinks.empty()) && output) {
      const auto out_start = Clock::now();
      if (csv) csv->row(runner->t(), runner->q(), d);
      for (FrameSink* s : sinks) s->frame(runner->t(), runner->q(), runner->p(), d);
      // On disk every few seconds: a killed run keeps what was written up to the last flush.
      if ((csv || h5) && std::chrono::duration<double>(out_start - last_flush).count() >= kFlushSeconds) {
        if (csv) csv->flush_to_disk();
        if (h5) h5->flush_to_disk();
        last_flush = Clock::now();
      }
      output_s += seconds_since(out_start);
    }
    if (summary.status == Status::Ok && checkpoint_due(k)) {
      const auto checkpoint_start = Clock::now();
      const double before = loop.seconds;  // the integration's seconds before this process
      loop.seconds = before + seconds_since(loop_start) - output_s - companion_s;
      write_checkpoint_now(k);
      loop.seconds = before;
      output_s += seconds_since(checkpoint_start);
    }
    if (progress && (k & 15) == 0) progress->update(k);  // it reads the clock: not every step
  }
  const double loop_s = loop.seconds + seconds_since(loop_start) - output_s - companion_s;
  // The final checkpoint: the state the loop ended in (before the summary's verdicts below, which
  // a resumed run makes afresh at its own end).
  if (!config.checkpoint_path.empty()) {
    loop.seconds = loop_s;
    write_checkpoint_now(summary.steps);
  }
  summary.stability_ratio = stability.ratio();
  if (summary.status == Status::Ok) {
    for (const std::string& w : {stability.warning(), precision.warning()})
      if (!w.empty()) summary.warning += (summary.warning.empty() ? "" : " ") + w;
  }
  if (const DoublingEstimate* w = summary.steps > 0 ? runner->accuracy() : nullptr) {  // no step: nothing to judge
    summary.error_estimate = w->estimate();
    summary.extent = w->extent();
    if (w->failed_samples() > 0 && summary.status == Status::Ok)  // a failed run says it all
      summary.warning += (summary.warning.empty() ? "" : " ") + std::string("the accuracy check's step of 2 dt failed ") +
                         std::to_string(w->failed_samples()) + " times (first at " + w->first_failure() +
                         "): dt is within a factor 2 of what the method can take here; the estimate covers the "
                         "samples that worked";
  }
  // A run without a step compared nothing: no estimate.
  summary.has_error_estimate = config.error_estimate;
  if (config.error_estimate) {
    const double in_run = summary.error_estimate;
    summary.error_estimate =
        summary.steps > 0 ? run.companion.scale * difference : std::numeric_limits<double>::quiet_NaN();
    // Richardson's factor assumes the asymptotic regime; where the accuracy check saw steps outside
    // it (a step of 2 dt and two of dt differing by more than 1 % of the speed), the companion
    // understates (the inertia-1e-10 chain: 0.22 for 0.49), and the check's own sum stands.
    const DoublingEstimate* w = runner->accuracy();
    if (w && w->fast_samples() > 0 && in_run > summary.error_estimate) summary.error_estimate = in_run;
  }
  if (csv) csv->close();
  for (FrameSink* s : sinks) s->end();
  summary.t_final = runner->t();
  summary.rhs_evaluations = runner->rhs_evaluations();
  if (choice.adaptive_on()) {
    summary.tol = choice.adaptive.tol;
    summary.adaptive_steps = runner->internal_steps();
    summary.rejected = runner->rejected();
  }
  summary.factorizations = runner->factorizations();
  if (summary.restarts >= 0) summary.restarts = runner->restarts();
  if (model.has_rigid_bodies()) summary.legendre_iterations_max = runner->legendre_iterations();
  if (forced) summary.energy_post_rel_err_max = std::numeric_limits<double>::quiet_NaN();  // not an invariant
  if (summary.status == Status::Ok && summary.parasitic_max > kParasiticWarning)
    summary.warning += (summary.warning.empty() ? "" : " ") + parasitic_warning(summary, choice.rattle);
  // ARKODE stops at every output time (--dt): one step per interval means that its error
  // control wanted longer steps than --dt allowed, at the cost of evaluations.
  const long internal = runner->internal_steps();
  if (choice.adaptive_on() && summary.steps >= 4 && internal <= 2 * (summary.steps + summary.steps / 16))
    summary.warning += (summary.warning.empty() ? "" : " ") +
                       std::string("the adaptive steps took about one pair per output interval (") +
                       std::to_string(internal) + " steps for " + std::to_string(summary.steps) +
                       " intervals): --dt, the output interval, probably capped them; a larger --dt lets the error "
                       "control choose longer steps";
  else if (!choice.adaptive_on() && internal >= 0 && summary.steps >= 4 && internal <= summary.steps + summary.steps / 16)
    summary.warning += (summary.warning.empty() ? "" : " ") +
                       std::string("ARKODE took about one step per output interval (") + std::to_string(internal) +
                       " steps for " + std::to_string(summary.steps) +
                       " intervals): --dt, its output interval, probably capped its step; a larger --dt lets "
                       "its error control choose longer steps (fewer evaluations at the same tolerance)";
  if (!companion_failure.empty()) summary.warning += (summary.warning.empty() ? "" : " ") + companion_failure;
  if (runner->accuracy() && summary.steps > 0)
    judge_accuracy(summary, config, reflection ? choice.rattle.order : config.method == "rk4" ? 4
                                                                    : config.method == "dla-left" ? 1 : 2,
                   *runner->accuracy(), reflection);  // after the warnings it may add to
  summary.ns_per_step = summary.steps > 0 ? 1e9 * loop_s / static_cast<double>(summary.steps) : 0.0;
  summary.ns_per_body_step = summary.ns_per_step / summary.bodies;
  if (final_q) *final_q = runner->q();
  if (final_state) {
    final_state->p = runner->p();
    final_state->coordinates = model.coordinate_names();
    final_state->velocities = model.velocity_names();
  }
  if (h5) h5->finish(summary);  // the summary's attributes, then the file is closed
  return summary;
}

namespace {

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

RunSummary run_scene(const RunConfig& given) {
  const auto start_time = Clock::now();
  std::string resume;
  if (!given.resume_path.empty()) resume = read_checkpoint(given.resume_path);
  const RunConfig config = resume.empty() ? given : resumed_config(given, resume);
  PreparedRun run = prepare_run(config);
  run.resume = std::move(resume);
  Parameters params = run.info.defaults();
  for (const auto& a : config.assignments) params.assign(a);
  Progress progress(run.info.name, run.steps);
  RunSummary summary = integrate_scene(run, params, config, &progress, nullptr, &progress);
  progress.finish();
  summary.wall_s = seconds_since(start_time);
  return summary;
}

}  // namespace nonholo::scenarios
