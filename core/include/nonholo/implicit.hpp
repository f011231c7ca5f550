#pragma once
/// @file
/// The general form of the method (docs/design.md §2, first display) for a configuration-
/// dependent metric M(q), with the midpoint discrete Lagrangian
/// ~~~{.unparsed}
///   Ld(q0, q1) = (1/2h) (q1 - q0)^T M((q0 + q1)/2) (q1 - q0) - (h/2)(V(q0) + V(q1)):
///   p-_k = (P - Q)*_{q_k} p+_k,   -D1 Ld(q_k, q_{k+1}) - (h/2) F_k = p-_k   (Newton for q_{k+1}),
///   p+_{k+1} = D2 Ld(q_k, q_{k+1}) + (h/2) F_{k+1},
/// ~~~
/// with the projectors M(q_k)-orthogonal. For a constant metric it is the explicit RATTLE of
/// rattle.hpp; use this one for models with ModelBuilder::configuration_metric. Dense linear
/// algebra: meant for small systems.
#include <nonholo/model.hpp>
#include <nonholo/restart_options.hpp>
#include <nonholo/sparse/message.hpp>
#include <nonholo/status.hpp>
#include <nonholo/time_grid.hpp>
#include <nonholo/workspace.hpp>

#include <cstdarg>

#include <Eigen/Dense>

namespace nonholo {

/// The options of implicit_step().
struct ImplicitOptions {
  double h = 0.01;  ///< time step
  /// Newton stops when the residual of the momentum equation is below newton_tolerance times
  /// its scale (|M Delta / h| + |p-|), or when round-off stops its decrease ...
  double newton_tolerance = 1e-14;
  int max_newton_iterations = 30;  ///< ... or fails with Status::NewtonNotConverged.
  double min_pivot_ratio = 1e-12;  ///< smallest accepted pivot of C relative to its diagonal (RattleOptions)
  /// The period-2 mode, as in RattleOptions: with p+ = p~ - (h/2) mu^T lambda~ (p~ = P* p+, the
  /// average momentum) the multiplier lambda~ is measured against the continuous one (with the
  /// metric's Christoffel terms) and restarted keeping the energy of p+ - (h/2) f (with the
  /// potential averaged as the explicit restart does). A model with momentum maps is not
  /// restarted by this form (Status::RestartFailed): use RestartMode::Never.
  RestartOptions restart = {};
};
void validate(const ImplicitOptions& options);  ///< throws std::invalid_argument

/// (t_k, q_k, p+_k): the momentum arriving at q_k.
struct ImplicitState {
  double t = 0.0;  ///< t_k
  TimeGrid grid;  ///< t_k = t0 + k h (time_grid.hpp)
  /// q_k and p+_k (n entries each).
  ///@{
  Vector q, p;
  ///@}
  int newton_iterations = 0;  ///< taken by the last step
  /// Steps taken and multiplier restarts since the start.
  ///@{
  long steps = 0, restarts = 0;
  ///@}
  ModeWatch watch;  ///< when the period-2 mode is measured next (restart_options.hpp)
};

/// Dense buffers sized once from the model (n coordinates, m one-forms).
class ImplicitWorkspace {
 public:
  /// For a model with a configuration metric (throws std::invalid_argument otherwise).
  explicit ImplicitWorkspace(const Model& model);
  explicit ImplicitWorkspace(const Model&& model) = delete;  // it keeps a pointer to the model
  const Model& model() const { return *model_; }  ///< the model it was sized for
  const char* message() const { return message_.c_str(); }  ///< why the last failed call failed
  /// Held by implicit_start and implicit_step for the call (busy_flag.hpp).
  BusyFlag& busy_flag() { return busy_; }
  /// Records the message (printf format) and returns status.
  Status fail(Status status, const char* format, ...) __attribute__((format(printf, 3, 4)));

  /// The average momentum P* p+ at q (in `average`) and the reflected (P - Q)* p+ (in
  /// `reflected`); fails on dependent one-forms.
  Status reflect(ConstVecRef q, ConstVecRef p_plus, VecRef average, VecRef reflected, double min_pivot_ratio);
  /// (1/2) p^T M(q)^-1 p.
  double kinetic_energy(ConstVecRef q, ConstVecRef p);

  /// Dense matrices: M(q), a dM/dq_i and Newton's Jacobian (n x n), mu (m x n), W = M^-1 mu^T
  /// (n x m) and C = mu W (m x m).
  ///@{
  Eigen::MatrixXd metric, dmetric, jacobian, mu, w, c;
  ///@}
  /// The Cholesky factorisations of M(q) and C, and the LU of the Jacobian.
  ///@{
  Eigen::LLT<Eigen::MatrixXd> metric_llt, c_llt;
  Eigen::PartialPivLU<Eigen::MatrixXd> jacobian_lu;
  ///@}
  /// The step's vectors (n entries unless said): Newton's unknown delta = q_{k+1} - q_k, the
  /// momentum equation's residual and right-hand side p-_k + (h/2) F_k, the terms
  /// delta^T dM/dq_i delta, q_mid, q_{k+1}, p-_k, p+_{k+1}, the applied force, scratch, the
  /// values of mu (nnz), a multiplier (m) and more scratch.
  ///@{
  Vector delta, residual, rhs, terms, q_mid, q_next, p_minus, p_next, force, scratch, mu_values, lambda, y;
  ///@}
  /// The period-2 mode: the average momentum and its velocity, the Christoffel term, the
  /// continuous multiplier's parts (force, and quadratic in the velocity), the restart's a and
  /// c, and a Workspace for the one-forms' bias (its difference quotient needs scratch).
  ///@{
  Vector p_tilde, velocity, gamma, lambda_f, lambda_b, mode_a, mode_c;
  Workspace bias;
  ///@}
  /// What the last successful step found (as Workspace::parasitic and restarted).
  ///@{
  double parasitic = 0.0;
  bool restarted = false;
  ///@}

 private:
  const Model* model_;
  sparse::Message message_;
  BusyFlag busy_;
};

/// Consistent start from a velocity guess: p~_0 = M(q0) v projected M(q0)-orthogonally onto
/// D(q0), lambda(0) of the index-reduced equations (with the metric's Christoffel terms), and
/// p+_0 = p~_0 - (h/2) mu_0^T lambda(0) (p+ is the explicit method's p_{k-1/2} + (h/2) f_k, so
/// P* p+ = p~). Throws on bad sizes or dependent one-forms.
ImplicitState implicit_start(const Model& model, ImplicitWorkspace& ws, double t0, ConstVecRef q0,
                             ConstVecRef v_guess, const ImplicitOptions& options);

/// One step, then the period-2 mode as options.restart asks (ws.parasitic, ws.restarted); never
/// throws or allocates; on failure the state is unchanged.
Status implicit_step(const Model& model, ImplicitWorkspace& ws, ImplicitState& state,
                     const ImplicitOptions& options);

}  // namespace nonholo
