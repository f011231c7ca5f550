#pragma once
// The integration methods behind `nonholo run --method`, one interface for the run loop:
// advance one output interval, then report the configuration and the diagnostics.
#include <nonholo/accuracy.hpp>
#include <nonholo/adaptive.hpp>
#include <nonholo/archive.hpp>
#include <nonholo/diagnostics.hpp>
#include <nonholo/rattle.hpp>
#include <nonholo/reference/integrators.hpp>
#include <nonholo/scenarios/run_types.hpp>
#include <nonholo/scenarios/scene.hpp>

#include <functional>
#include <limits>
#include <memory>
#include <string>

namespace nonholo::scenarios {

class Runner {
 public:
  virtual ~Runner() = default;
  // Integrates to t_next (one output interval later). On failure the state is the last good.
  virtual Status advance(double t_next) = 0;
  virtual double t() const = 0;
  virtual ConstVecRef q() const = 0;
  // energy, energy_post (NaN for methods without post-momenta), residual |mu v|, gap.
  virtual Diagnostics diagnostics() = 0;
  // J(q, p) of the model's momentum maps, p the momentum the method carries.
  virtual void momentum_maps(VecRef out) = 0;
  // That momentum (reflection and DLA: p~ of the state; the implicit form: its state's p;
  // the reference methods: M v), for the HDF5 output's /p.
  virtual ConstVecRef p() = 0;
  virtual std::string message() const = 0;
  virtual std::string backend() const = 0;
  virtual int threads() const { return 1; }  // threads one step uses
  // The threads that run them (Workspace::set_team: the same results; team_probe.hpp).
  virtual void set_team(int) {}
  virtual long rhs_evaluations() const { return -1; }  // -1: not counted
  // ARKODE and adaptive composed steps: their own steps so far (-1 for the fixed-step methods).
  virtual long internal_steps() const { return -1; }
  // Adaptive composed steps: the rejected pairs so far (-1 for the other methods).
  virtual long rejected() const { return -1; }
  // Numeric factorisations of C so far (-1: not counted, the dense implicit form).
  virtual long factorizations() const { return -1; }
  // Reflection only: the parasitic amplitude measured by the last step (NaN if not measured)
  // and the restarts so far (-1 for the other methods).
  virtual double parasitic() const { return std::numeric_limits<double>::quiet_NaN(); }
  virtual long restarts() const { return -1; }
  // Reflection on a model with rigid bodies: the most Newton iterations a discrete Legendre
  // transform has taken (-1 for the other methods).
  virtual long legendre_iterations() const { return -1; }
  // The velocity the diagnostics are of (reflection: M^-1 p~; DLA: M^-1 p_{k-1/2}; the
  // reference methods: v; the implicit form: M(q)^-1 P* p+), n_v entries. Valid after
  // diagnostics(), until the runner's next call (it may be the workspace's scratch); the run's
  // work and precision checks use it.
  virtual ConstVecRef velocity() = 0;
  // relative_residual (run_checks.hpp) of velocity() at q: |mu_i v| / (|mu_i|_1 |v|_inf) at
  // its largest; 0 without one-forms, NaN if mu(q) is not finite. After diagnostics().
  virtual double relative_residual() = 0;
  // The workspace whose factorisation holds C(q()) between steps, when the method has one
  // (the stability watch borrows it instead of building its own).
  virtual Workspace* workspace() { return nullptr; }
  // The in-run accuracy check (nonholo/accuracy.hpp): the estimated global error in q so far,
  // NaN for a method without one or with the check off; and the watch itself, when there is one.
  virtual const DoublingEstimate* accuracy() const { return nullptr; }
  // Checkpoints: everything the next steps and the summary read (state, watches, counters), at
  // a step boundary. Throws std::runtime_error for a method whose state cannot be saved (ARKODE)
  // or bytes of another run.
  virtual void save(OutArchive& a) const = 0;
  virtual void load(InArchive& a) = 0;
  // A stop request (Ctrl-C, SIGTERM, the caller), asked between the internal steps of an output
  // interval where a method takes many (adaptive pairs): advance() then returns
  // Status::Interrupted with the state at the last finished one.
  void set_stop(std::function<bool()> stop) { stop_ = std::move(stop); }

 protected:
  std::function<bool()> stop_;
};

// The most steps (adaptive: pairs) a run may take, as the fixed-step runs' t_end / dt.
inline constexpr double kMaxRunSteps = 1e12;

struct MethodChoice {
  std::string method = "reflection";  // or rk4, arkode-dp5, arkode-verner, arkode-fehlberg8
  RattleOptions rattle;               // reflection
  reference::Options reference;       // the others
  sparse::Backend backend = sparse::Backend::Auto;
  int threads = 1;  // reflection: WorkspaceOptions::threads (RunConfig::threads resolved for the model)
  // Steps between two samples of the accuracy check (0: off; docs/guide/methods.md "Accuracy check").
  int accuracy_every = 32;
  // Reflection, orders 4-8: adaptive composed steps when tol > 0 (RunConfig::adaptive).
  AdaptiveOptions adaptive = no_adaptive();
  bool adaptive_on() const { return adaptive.tol > 0.0; }

 private:
  static AdaptiveOptions no_adaptive() {
    AdaptiveOptions o;
    o.tol = 0.0;
    return o;
  }
};

// The companion trajectory of an error estimate (--error-estimate): the same method at h/2
// (ARKODE: at tol/100), and the factor that turns the difference in q into an estimate of
// the error of the method itself: 2^p / (2^p - 1) for a fixed-step method of order p, whose
// error at h/2 is 2^-p of that at h; 1 for ARKODE, whose error falls about in proportion to
// its tolerance.
struct Companion {
  MethodChoice choice;
  double scale = 1.0;
  // The accuracy check's companion (check_companion_of): how many times the run's error its own
  // is, to leading order; and every how many of the run's steps (output intervals) it advances.
  double ratio = 0.0;
  int stride = 1;
};
Companion companion_of(const MethodChoice& choice);

// The accuracy check's companion (RunConfig::accuracy_check), without an accuracy check of its
// own, for the methods with one (the reflection step and RK4; not the baselines or ARKODE): the
// same method at 2 h, advanced every two steps, whose error is 2^p times the run's. Adaptive
// steps: at 10 tol, advanced every two output intervals (and to the last), so that it differs
// from the run where the intervals cap the steps (there its error is 2^p times the run's) as
// where the tolerance sets them (ratio 10: the controller keeps the local error per unit time in
// proportion to tol). Above tol 0.05 (AdaptiveOptions::tol stays below 1) at tol / 10 instead,
// advanced with the run (ratio 0.1).
Companion check_companion_of(const MethodChoice& choice);

// Told the name of each phase of a runner's set-up as it begins ("analysing C": the workspace
// and the factorisation's analysis; "starting": the consistent initial state), for the set-up
// status line (progress.hpp). May be empty.
using SetupPhase = std::function<void(const char* phase)>;

// Starts the method on `model` (kept by reference) from `start`: the consistent initial state
// start_from_velocity makes of q0 and v0, or the state given.
// Throws std::invalid_argument for an unknown method, or order 4 or 6 with another method
// than the explicit reflection step.
std::unique_ptr<Runner> make_runner(const Model& model, const RunStart& start, const MethodChoice& choice,
                                    const SetupPhase& phase = {});

}  // namespace nonholo::scenarios
