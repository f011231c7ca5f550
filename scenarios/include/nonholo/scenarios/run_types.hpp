#pragma once
/// @file
/// The types of `nonholo run` without its functions: the options (RunConfig), where frames go
/// (FrameSink) and what a run did (RunSummary). Every room of the scenarios uses them (the
/// output files write them, checkpoints save them), so they stand apart from run_scene()
/// (<nonholo/scenarios/run.hpp>); RunSummary::line() and fields() belong to the output.
#include <nonholo/diagnostics.hpp>
#include <nonholo/rattle.hpp>
#include <nonholo/sparse/factorization.hpp>
#include <nonholo/state.hpp>
#include <nonholo/status.hpp>

#include <atomic>
#include <functional>
#include <limits>
#include <optional>
#include <string>
#include <vector>

namespace nonholo::scenarios {

/// Where a run's frames go besides the CSV (Python's arrays, say): begin() once with the
/// coordinate names, frame() at t_0 and at every `every`-th step and the last (p: the momentum
/// the method carries, p~ for the reflection method), end() after the last frame, also when a
/// step failed. Not owned by the run; called from its thread.
class FrameSink {
 public:
  virtual ~FrameSink() = default;
  virtual void begin(const std::vector<std::string>& coordinates) = 0;  ///< the names of q's entries
  /// Called before begin() with the names of p's entries (n_v of them; with 3-D rigid bodies not
  /// the coordinates': wx0, wy0, wz0, vx0, ...).
  virtual void velocities(const std::vector<std::string>& names) { (void)names; }
  virtual void frame(double t, ConstVecRef q, ConstVecRef p, const Diagnostics& d) = 0;  ///< one frame
  virtual void end() {}  ///< after the last frame
  /// Polled between steps: true ends the run with status=interrupted, as Ctrl-C does.
  virtual bool stop_requested() { return false; }
  /// After every step: the time reached and the fraction of the run's steps done (1 at its
  /// end). Called on the run's thread before stop_requested(); keep it cheap.
  virtual void progress(double t, double fraction) {
    (void)t;
    (void)fraction;
  }
};

/// RunConfig::threads = 0 gives a chain with one-form hitches a thread per this many bodies, up
/// to the usable cores: fewer bodies a thread and the threads' synchronisation at every step
/// costs more than they save (measured on a 2-core AMD EPYC, default options: 2 threads 1.15
/// times faster than one at 1000 bodies, 1.44 at 10^4, docs/results/threads.md).
inline constexpr int kBodiesPerThread = 500;
/// ... and with holonomic hitches, whose step meets its threads three times more (the gap
/// corrections' passes): on the same machine 2 threads were 1.1-1.2 times slower than one at
/// 1000 bodies, even at 2000 and 4000, 1.1-1.45 times faster at 10^4.
inline constexpr int kHolonomicBodiesPerThread = 5000;

/// RunConfig::accuracy_check "auto" runs the companion for models of up to this many velocities
/// (10^5 planar bodies): above, its second state and workspace (half the run's memory again) and
/// half the run's time again are what scaling runs cannot spare, and the sampled check runs.
inline constexpr long kCompanionMaxVelocities = 300000;

/// A condition that ends a run where it first holds (RunConfig::stop_conditions; the built-in
/// ones as text in RunConfig::stop_when): checked after every `every`-th step and the last, and
/// where it holds, the first time it held between the last two checks is found by bisection on
/// the interpolant (cubic Hermite in q and the velocity; linear for a model with 3-D rigid
/// bodies, whose q holds quaternions). The run then ends with status=stopped; the summary's
/// stopped_by and t_stop say which condition and when; the output holds every frame up to the
/// step where it was seen (that one written whatever RunConfig::every). A condition that holds at
/// the start ends the run before its first step.
struct StopCondition {
  std::string name;  ///< how the summary names it (one word: whitespace becomes '_')
  /// Whether the run should stop at (t, q). Called on the run's thread, also at interpolated
  /// states; an exception ends the run with status=callback-failed naming the condition.
  std::function<bool(double t, ConstVecRef q)> holds;
  long every = 1;  ///< checked every so many steps (and after the last), at least 1
};

/// Where a model built in code starts (run_model(), <nonholo/scenarios/run.hpp>): at t0 from q0
/// with the velocity guess v0, projected onto the constraints as start_from_velocity does (the
/// scenes' start), or from a State already consistent (one that start_from_velocity or step()
/// made), which the reflection method continues as it is.
struct RunStart {
  double t0 = 0.0;  ///< the start time (the run ends at RunConfig::t_end, a time, not a duration)
  Vector q0;        ///< n_q entries
  Vector v0;        ///< n_v entries: the velocity guess
  /// Instead of t0, q0 and v0: this state (its t, q, p~ and lambda~). The other methods start
  /// from its q and M^-1 p~.
  std::optional<State> state;
};

/// The options of `nonholo run` (run_scene()) and of a run of a model built in code (run_model()).
struct RunConfig {
  /// A built-in scene's name, or a scene file (.json). run_model(): the model's name in the
  /// summary and the output files (empty: "model").
  std::string scene;
  std::vector<std::string> assignments;  ///< NAME=VALUE, applied in order
  double dt = 0.0;                       ///< 0: the scene's default (run_model(): required)
  double t_end = -1.0;                   ///< < 0: the scene's default (run_model(): required)
  std::string csv_path;                  ///< empty: no CSV
  FrameSink* sink = nullptr;             ///< also gets the frames (run_scene only, not batch)
  /// Stop conditions without code (`--stop-when`, saved in checkpoints), each checked after every
  /// step: "NAME>VALUE" or "NAME<VALUE" for a coordinate (`x0>10`), "hitch-angle>VALUE" (the
  /// largest |theta_i - theta_{i+1}| of consecutive planar bodies, radians: a jack-knife),
  /// "gap>VALUE" (the largest |g(q)| of the holonomic constraints).
  std::vector<std::string> stop_when;
  /// Stop conditions in code (not saved in checkpoints: a resumed run is given them again).
  std::vector<StopCondition> stop_conditions;
  /// Read between steps, set from any thread (not owned): true ends the run with status=interrupted,
  /// as Ctrl-C does; a batch then starts no more trajectories (Python's batch, on Ctrl-C).
  const std::atomic<bool>* stop = nullptr;
  long every = 1;                        ///< write every K-th step (and the last)
  sparse::Backend backend = sparse::Backend::Auto;  ///< the factorisation of C (`--backend`)
  /// Threads for one step of the chain (`--threads`, WorkspaceOptions::threads; reflection
  /// method): 0 picks them: for a chain of knife edges and hitches a thread per
  /// kBodiesPerThread bodies (kHolonomicBodiesPerThread with holonomic hitches), up to the cores
  /// the process may use, else 1. A batch runs each trajectory on one.
  int threads = 0;
  HitchMode hitch = HitchMode::Holonomic;  ///< reflection: how hitches are kept (`--hitch`)
  std::string restart = "auto";  ///< see set_restart (restart_options.hpp): auto, 0 or K
  double restart_tol = 0.0;      ///< RestartOptions::tolerance (0: min(dt^3, 1e-3))
  int monitor_every = 8;         ///< RestartOptions::monitor_every
  std::string method = "reflection";  ///< or rk4, arkode-dp5, arkode-verner (6(5)), arkode-fehlberg8 (8(7))
  int order = 2;                      ///< reflection: 2, or 4 and 6 by composition
  std::string composition = "auto";   ///< see composition_from_string (composition.hpp)
  std::string rotation = "moser-veselov";  ///< rigid bodies: see rotation_from_string (rattle_options.hpp)
  /// Integrate a companion trajectory at dt/2 (ARKODE: tol/100) in the same run and report
  /// error_estimate (README "Error estimate").
  bool error_estimate = false;
  /// The accuracy check (README "Accuracy check"): status=inaccurate when the estimated error in q
  /// exceeds this fraction of the motion's extent (the widest range a coordinate swept). 0: off.
  double accuracy = 0.1;
  /// How the accuracy check estimates the error (README "Accuracy check"): "companion" (a second
  /// trajectory at 2 dt, adaptive steps at 10 tol, integrated alongside and compared: it sees
  /// errors that grow, half the run's cost again), "sampled" (sampled step doubling: a few per cent,
  /// blind to growth; fixed steps only), or "auto" (the companion up to kCompanionMaxVelocities
  /// velocities, sampled above; adaptive steps always the companion).
  std::string accuracy_check = "auto";
  bool project = false;  ///< reference methods: project onto the constraints after each step
  double tol = 1e-8;     ///< ARKODE methods: relative and absolute tolerance; see adaptive
  /// Reflection: adaptive steps (nonholo/adaptive.hpp; order 2 restarts at every step) aiming at
  /// an error `tol` in q at t_end; dt is then the output interval, which the steps land on.
  bool adaptive = false;
  double horizon = 0.0;  ///< adaptive: the run length the error budget is spread over (0: t_end)
  std::string command_line;  ///< how the run was asked for (the output files' "command" attribute)
  /// What the run writes to standard error (the command line's --quiet, --verbose): 0, nothing
  /// (not the progress bar); 1, the progress bar and set-up status on a terminal; 2, also as lines
  /// where standard error is no terminal (a log): each set-up phase and the progress every 10 s.
  int verbosity = 1;

  /// Checkpoints (README "Long runs"): the whole state of the run written to this HDF5 file at
  /// its end (also when it fails or is interrupted) and, if set, every so many steps or seconds
  /// (atomically: a crash mid-write keeps the previous one). Empty: none.
  ///@{
  std::string checkpoint_path;
  long checkpoint_every_steps = 0;
  double checkpoint_every_seconds = 0.0;
  ///@}
  /// Continue the run saved in this checkpoint: its options replace this config's, except
  /// t_end (when >= 0: run on to it), the checkpoint settings above, sink and stop. The output
  /// file is continued from where the checkpoint left it (rows written after it are dropped).
  std::string resume_path;
};

/// What a warning of a run is about (RunWarning; Python: a category of the warnings module,
/// nonholo.AccuracyWarning and its siblings).
enum class WarningKind {
  Accuracy,     ///< the accuracy check could not judge as it should (its companion or samples failed)
  Stability,    ///< dt within a factor 2 of the explicit step's stability limit
  Precision,    ///< coordinates large enough to lose digits of a step's displacement
  Method,       ///< the method's own behaviour: a grown period-2 mode
  Performance,  ///< the run could go faster: threads that do not help, steps capped by the output
};
/// "accuracy", "stability", "precision", "method", "performance".
const char* to_string(WarningKind kind);

/// One warning of a run that ended (RunSummary::warnings): its kind and its text, with the change
/// that would help.
struct RunWarning {
  WarningKind kind;  ///< what it is about
  std::string text;  ///< what the command line prints after "warning: "
};

/// One key=value of the summary line, with its value unrounded (the line prints 6 digits).
struct SummaryField {
  std::string key;  ///< as the line prints it ("energy_rel_err_max", ...)
  /// @enum Kind
  /// Which of number, integer and text holds the value.
  /// @var Number
  ///   number
  /// @var Integer
  ///   integer
  /// @var Text
  ///   text
  enum Kind { Number, Integer, Text } kind;  ///< which member holds the value
  double number;  ///< the value of a Number
  long integer;  ///< the value of an Integer
  std::string text;  ///< the value of a Text
};

/// What a run did: the summary line's values (docs/reference/summary.md explains each key).
struct RunSummary {
  std::string scene;  ///< the scene's name, or the scene file's path
  std::string method;  ///< reflection, dla-midpoint, dla-left, rk4, arkode-dp5, ...
  std::string backend;  ///< the factorisation of C in use (sparse::to_string)
  std::string hitch;  ///< how holonomic constraints were kept (holonomic, oneform, velocity, projected)
  std::string restart;  ///< the restart policy in use (reflection), "" for the other methods
  int order = 0;            ///< reflection: 2, 4, 6 or 8 (0: the other methods)
  std::string composition;  ///< reflection with order 4, 6: the composition's name
  int bodies = 0;  ///< bodies in the model
  int threads = 0;  ///< threads one step used (`nonholo run`; 0: not reported, as in a batch's aggregate)
  Status status = Status::Ok;  ///< how the run ended
  std::string message;  ///< why the run stopped early
  /// A run ended by a stop condition (status=stopped, or a verdict found after it): the
  /// condition's name, and the first time it held, found on the interpolant between its last two
  /// checks (NaN: none held).
  ///@{
  std::string stopped_by;
  double t_stop = std::numeric_limits<double>::quiet_NaN();
  ///@}
  long steps = 0;  ///< steps taken (adaptive steps and ARKODE: output intervals)
  double dt = 0.0;  ///< the step, or the output interval
  double t_final = 0.0;  ///< the time reached (the line's t_end)
  double wall_s = 0.0;       ///< whole run: set-up, integration, diagnostics, output
  /// Set-up: from the run's start to its first step (the model, the workspaces, the start state,
  /// the outputs opened); a batch's line: the mean over its trajectories. Like wall_s, not repeatable.
  double setup_s = 0.0;
  double ns_per_step = 0.0;  ///< integration and per-step diagnostics, without set-up or CSV
  double ns_per_body_step = 0.0;  ///< ns_per_step / bodies
  /// The largest relative change of the energy of the state, and of the post-momentum's energy.
  ///@{
  double energy_rel_err_max = 0.0;
  double energy_post_rel_err_max = 0.0;
  ///@}
  double residual_max = 0.0;  ///< max over the steps of max_a |(mu(q_k) v_k)_a|: absolute
  /// max_a |(mu v)_a| / (|mu_a|_1 |v|_inf) (run_checks.hpp) at its largest over the start, the
  /// first step, every 7th and the last: the residual relative to the scale of the row and of
  /// the velocity, the one the run's bound applies to.
  double residual_rel_max = 0.0;
  double gap_max = 0.0;  ///< max over the steps of max_j |g_j(q_k)| (hitches; 0 without)
  /// Reflection: multiplier restarts, and the largest parasitic amplitude measured (NaN if none).
  ///@{
  long restarts = -1;  ///< -1: not applicable (other methods)
  double parasitic_max = 0.0;
  ///@}
  /// Models with external forces: the work they did (NaN in a batch, where it is not summed) and
  /// the balance error of the energy against it; energy_rel_err_max is then also net of the
  /// work. The order-2 reflection step: sum_k h F_k^T M^-1 p~_k, its discrete identity, and the
  /// post-momentum's energy; the other methods and orders: the integral of F^T v by Gregory's
  /// rule from the step ends (run_checks.hpp), and the energy the method reports.
  ///@{
  bool has_work = false;
  double work = 0.0;
  double energy_balance_err_max = 0.0;
  ///@}
  std::string warning;  ///< what the user should know about a run that ended ok: warnings' texts, joined
  /// The same one by one, with their kinds (the line's `warnings=` lists the kinds).
  std::vector<RunWarning> warnings;
  /// What the clock showed about the chain's threads: empty, or that one thread ran its steps
  /// faster and for how many it did (the same results). Like wall_s, not repeatable.
  std::string threads_note;
  long rhs_evaluations = -1;  ///< reference methods: evaluations of the equations
  /// Adaptive composed steps (RunConfig::adaptive): the tolerance, the accepted composed steps
  /// and the rejected pairs (-1: fixed steps). steps counts the output intervals then.
  ///@{
  double tol = std::numeric_limits<double>::quiet_NaN();
  long adaptive_steps = -1;
  long rejected = -1;
  ///@}
  long factorizations = -1;   ///< numeric factorisations of C (-1: not counted)
  /// The estimated max error in q (max norm). With RunConfig::error_estimate: max over the output
  /// times of |q - q^|_inf against the companion trajectory q^, scaled by 2^p / (2^p - 1) for a
  /// fixed-step method of order p (Richardson). Otherwise the in-run accuracy check's estimate
  /// (nonholo/accuracy.hpp). NaN when not computed (also when the run took no step: refused
  /// before it, or its first step failed).
  double error_estimate = std::numeric_limits<double>::quiet_NaN();
  /// What error_estimate is judged against (the accuracy check): the widest range any coordinate
  /// swept, and the tolerance (a fraction of it; 0: the check is off). NaN: no check.
  ///@{
  double extent = std::numeric_limits<double>::quiet_NaN();
  double accuracy = std::numeric_limits<double>::quiet_NaN();
  ///@}
  /// Which estimate error_estimate is ("companion", "sampled"; "error-estimate" for
  /// RunConfig::error_estimate's); empty: none.
  std::string accuracy_check;
  /// Explicit fixed-step methods with applied forces: the largest dt / stability limit estimated
  /// (nonholo/stability.hpp); NaN when not applicable. A run refuses 1 or more, warns from 0.5.
  double stability_ratio = std::numeric_limits<double>::quiet_NaN();
  bool has_momentum = false;  ///< the model has momentum maps (momentum_drift_max shows)
  bool has_error_estimate = false;  ///< asked for (RunConfig::error_estimate): the key shows, nan or not
  double momentum_drift_max = 0.0;  ///< max over the momentum maps of |J_k - J_0|
  /// Reflection on a model with 3-D rigid bodies: the rotation Lagrangian, and the most Newton
  /// iterations a Legendre transform took in the run (-1: not applicable).
  ///@{
  std::string rotation;
  long legendre_iterations_max = -1;
  ///@}

  /// One line of space-separated key=value pairs: the fields below, numbers to 6 digits.
  std::string line() const;
  /// What the line shows, in its order (the keys present depend on the method and the model).
  std::vector<SummaryField> fields() const;
};

}  // namespace nonholo::scenarios
