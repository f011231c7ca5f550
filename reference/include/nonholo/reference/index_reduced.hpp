#pragma once
/// @file
/// The continuous equations of docs/design.md §1 in index-reduced, first-order form, the
/// equations standard ODE solvers integrate (the baselines of docs/design.md §2):
/// ~~~{.unparsed}
///   qdot = v,   M vdot = f + g + mu^T lambda,   C lambda = -(mu' v) - mu M^-1 (f + g),
/// ~~~
/// and the projection onto the constraints users often apply after each step. With 3-D rigid
/// bodies y = (q, v) has n_q + n_v entries: a body's quaternion follows qdot = q (x) (0, Omega)/2
/// (its norm is kept only up to the solver's error: rotations are read from q/|q|, and
/// Integrator::q() reports unit quaternions), and g = (I Omega) x Omega is the gyroscopic
/// force. Every evaluation factorises C(q) once through the model's Workspace; nothing allocates.
#include <nonholo/model.hpp>
#include <nonholo/status.hpp>
#include <nonholo/workspace.hpp>

/// The baselines: the index-reduced equations of a Model and standard integrators of them
/// (RK4, SUNDIALS ARKODE), to compare the reflection integrator against.
namespace nonholo::reference {

/// The right-hand side y' = F(t, y) of the index-reduced equations, y = (q, v) (see
/// index_reduced.hpp).
class IndexReducedOde {
 public:
  /// For `model`, which must outlive it; its Workspace is built with `options`.
  explicit IndexReducedOde(const Model& model, const WorkspaceOptions& options = {});
  // It keeps a pointer to the model: one built from a temporary would dangle.
  explicit IndexReducedOde(const Model&& model, const WorkspaceOptions& options = {}) = delete;

  const Model& model() const { return *model_; }  ///< the model
  int size() const { return model_->num_configuration() + model_->num_velocities(); }  ///< y = (q, v)
  /// The workspace every evaluation factorises C in.
  ///@{
  Workspace& workspace() { return ws_; }
  const Workspace& workspace() const { return ws_; }
  ///@}

  /// ydot = (v, vdot) at (t, y). y and ydot hold size() entries and must not alias.
  Status rate(double t, const double* y, double* ydot);
  /// Projects y = (q, v) onto the constraints: q onto g(q) = 0 when the model has holonomic
  /// rows (Gauss-Newton along M^-1 mu^T, until max|g| <= 1e-13 or 16 eps max|q|), then v
  /// M-orthogonally onto D(q).
  Status project(double* y);

  /// (1/2) v^T M v + V(q), max_a |(mu(q) v)_a| and max_j |g_j(q)|.
  ///@{
  double energy(const double* y);
  double residual(const double* y);
  double gap(const double* y);
  ///@}

 private:
  const Model* model_;
  Workspace ws_;
  Vector q_, v_, p_, lambda_, gyro_;  // scratch
};

}  // namespace nonholo::reference
