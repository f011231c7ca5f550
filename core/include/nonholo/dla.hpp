#pragma once
/// @file
/// The discrete Lagrange-d'Alembert baseline of Cortes and Martinez (docs/design.md §2), for a
/// constant metric and Ld = (1/2h) dq^T M dq - (h/2)(V(q_k) + V(q_k+1)), forces added as f_k:
/// ~~~{.unparsed}
///   p_{k+1/2} = p_{k-1/2} + h (f_k + mu(q_k)^T lambda_k),   q_{k+1} = q_k + h M^-1 p_{k+1/2},
/// ~~~
/// with the constraints discretised either at the left point, mu(q_k)(q_{k+1} - q_k) = 0
/// (explicit: one solve with C(q_k)), or at the midpoint, mu((q_k + q_{k+1})/2)(q_{k+1} - q_k)
/// = 0 (simplified Newton with the factorisation of C(q_k)). For comparison only.
#include <nonholo/model.hpp>
#include <nonholo/state.hpp>
#include <nonholo/status.hpp>
#include <nonholo/workspace.hpp>

#include <string>

namespace nonholo {

/// @enum DlaConstraint
/// Where the constraints are discretised (see dla.hpp).
/// @var DlaConstraint::Midpoint
///   mu((q_k + q_{k+1})/2)(q_{k+1} - q_k) = 0, by simplified Newton;
/// @var DlaConstraint::Left
///   mu(q_k)(q_{k+1} - q_k) = 0, explicit.
enum class DlaConstraint { Midpoint, Left };
const char* to_string(DlaConstraint c);  ///< "midpoint", "left"

/// The options of dla_step().
struct DlaOptions {
  double h = 0.01;  ///< time step
  DlaConstraint constraint = DlaConstraint::Midpoint;  ///< where the constraints are discretised
  /// Midpoint: iterate until max_a |mu_a(q_mid) (q_{k+1} - q_k)/h| <= newton_tolerance times
  /// that row's scale sum_i |mu_ai v_i| (or round-off stops the decrease) ...
  double newton_tolerance = 1e-14;
  int max_newton_iterations = 50;  ///< ... or fail with Status::NewtonNotConverged.
  double min_pivot_ratio = 1e-12;  ///< smallest accepted pivot of C relative to its diagonal (RattleOptions)
};
void validate(const DlaOptions& options);  ///< throws std::invalid_argument

/// (t_k, q_k, p_{k-1/2}): the configuration and the momentum of the step that arrived.
struct DlaState {
  double t = 0.0;  ///< t_k
  TimeGrid grid;  ///< t_k = t0 + k h (time_grid.hpp)
  /// q_k (n_q entries) and p_{k-1/2} (n_v).
  ///@{
  Vector q, p;
  ///@}
  int newton_iterations = 0;  ///< taken by the last midpoint step
};

/// A consistent start from a reflection State (start_from_velocity): p_{-1/2} = p~_0 -
/// (h/2)(f_0 + mu_0^T lambda(0)), so that the first step is second-order accurate.
DlaState dla_start(const State& start, double h);

/// One step; never throws or allocates; on failure the state is unchanged.
Status dla_step(const Model& model, Workspace& ws, DlaState& state, const DlaOptions& options);

}  // namespace nonholo
