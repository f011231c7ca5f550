#pragma once
/// @file
/// Reference integrators of the index-reduced equations (docs/design.md §2, baselines):
/// classical fixed-step RK4, and SUNDIALS ARKODE's adaptive explicit Runge-Kutta with the
/// Dormand-Prince 5(4), the Verner 6(5) or the Fehlberg 8(7) table. Each can project onto the
/// constraints after every step (positions onto g = 0 for holonomic rows, velocities onto D), as
/// users often do.
#include <nonholo/archive.hpp>
#include <nonholo/reference/index_reduced.hpp>

#include <memory>
#include <string>

namespace nonholo::reference {

/// @enum Method
/// The reference methods: classical RK4 and ARKODE's explicit pairs.
/// ArkodeVerner is the 8-stage 6(5) pair ARKODE_VERNER_8_5_6; ArkodeFehlberg8 the 13-stage
/// pair ARKODE_FEHLBERG_13_7_8, of order 8 with an embedded 7 (Verner's 8(7) pair,
/// ARKODE_VERNER_13_7_8, came with SUNDIALS 6.6; Debian bookworm ships 6.4.1).
/// @var Method::Rk4
///   classical fixed-step RK4;
/// @var Method::ArkodeDp5
///   ARKODE, Dormand-Prince 5(4);
/// @var Method::ArkodeVerner
///   ARKODE, Verner 6(5);
/// @var Method::ArkodeFehlberg8
///   ARKODE, Fehlberg 8(7).
enum class Method { Rk4, ArkodeDp5, ArkodeVerner, ArkodeFehlberg8 };
const char* to_string(Method method);  ///< "rk4", "arkode-dp5", "arkode-verner", "arkode-fehlberg8"
/// Throws std::invalid_argument naming the valid choices.
Method method_from_string(const std::string& name);

/// The options of an Integrator.
struct Options {
  double h = 0.01;       ///< RK4's step
  double tol = 1e-8;     ///< ARKODE: relative and absolute tolerance
  bool project = false;  ///< project onto the constraints after every step
  long max_steps = 100'000'000;  ///< ARKODE: internal steps allowed per advance_to
  sparse::Backend backend = sparse::Backend::Auto;  ///< factorisation of C at every evaluation
};
/// Throws std::invalid_argument for a non-positive h or tol, or tol < 1e-15.
void validate(const Options& options);

/// One of the reference methods on the index-reduced equations of a model.
class Integrator {
 public:
  /// Starts at (t0, q0, v0); v0 should lie in D(q0) (see start_from_velocity). Throws
  /// std::invalid_argument on sizes or options, std::runtime_error if ARKODE cannot start.
  Integrator(const Model& model, Method method, const Options& options, double t0, ConstVecRef q0,
             ConstVecRef v0);
  ~Integrator();
  Integrator(const Integrator&) = delete;
  Integrator& operator=(const Integrator&) = delete;

  /// Integrates to exactly t (> t()). RK4 takes whole steps of h and a last shorter one if
  /// needed; ARKODE stops at t, so its step never exceeds the interval between two calls. On
  /// failure the state is that of the last good step and message() says why.
  /// A call while another runs on this integrator (another thread, a model callback) returns
  /// Status::WorkspaceBusy (busy_flag.hpp).
  Status advance_to(double t);

  /// RK4 only: one step of size h from the current state into y_out (sized like y()), the state
  /// unchanged: the accuracy check's shadow step. Its evaluations are not counted in
  /// rhs_evaluations() but in trial_evaluations() (the workspace's factorisations count them).
  Status rk4_trial(double h, Vector& y_out);
  long trial_evaluations() const { return trial_rhs_; }  ///< evaluations of rk4_trial()

  double t() const { return t_; }  ///< the current time
  /// The configuration (rigid bodies' quaternions normalised; the solver's own state y() keeps
  /// them as integrated) and the velocity.
  ///@{
  ConstVecRef q() const;
  ConstVecRef v() const;
  ///@}
  const double* y() const { return y_.data(); }  ///< the solver's state (q, v), size() entries
  /// The equations it integrates.
  ///@{
  IndexReducedOde& ode() { return ode_; }
  const IndexReducedOde& ode() const { return ode_; }
  ///@}
  long steps() const { return steps_; }          ///< integrator steps taken so far
  long rhs_evaluations() const { return rhs_; }  ///< evaluations of the equations
  const std::string& message() const { return message_; }  ///< why the last failed call failed

  /// Checkpoints (archive.hpp), RK4 only: its state, time and counters. ARKODE's integrator keeps
  /// its step-size controller's history inside SUNDIALS, with no way to save it: both throw
  /// std::runtime_error for the ARKODE methods.
  ///@{
  void save(OutArchive& a) const;
  void load(InArchive& a);
  ///@}

 private:
  struct Arkode;  // keeps the SUNDIALS headers out of this one
  struct ArkodeDeleter {  // defined where Arkode is (arkode_solver.cpp or arkode_missing.cpp)
    void operator()(Arkode* arkode) const;
  };
  // The ARKODE methods (arkode_solver.cpp; without SUNDIALS, arkode_missing.cpp refuses them).
  void start_arkode(double t0);
  Status arkode_advance(double t);
  Status rk4_step(double h);
  Status fail(Status status, const std::string& why);

  IndexReducedOde ode_;
  Method method_;
  Options options_;
  double t_;
  Vector y_, k1_, k2_, k3_, k4_, tmp_;
  mutable Vector q_unit_;  // q() with unit quaternions (models with rigid bodies)
  long steps_ = 0, rhs_ = 0, trial_rhs_ = 0;
  std::string message_;
  std::unique_ptr<Arkode, ArkodeDeleter> arkode_;
  BusyFlag busy_;
};

}  // namespace nonholo::reference
