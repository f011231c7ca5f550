#pragma once
/// @file
/// The integrator state at t_k: (q_k, p~_k, lambda~_k) of docs/design.md §2, plus the total
/// generalised force f_k + mu_k^T lambda~_k that the next half kick needs. Keeping that force
/// with the state is the velocity-Verlet convention: one evaluation of mu per step. Create a
/// State with nonholo/start.hpp; the integrators keep the four fields consistent. A step
/// commits by swapping these vectors with the workspace's scratch (no copy), so their data()
/// pointers change from step to step: do not keep pointers into a State across steps.
#include <nonholo/restart_options.hpp>
#include <nonholo/time_grid.hpp>
#include <nonholo/types.hpp>

#include <limits>

namespace nonholo {

/// The reflection integrator's state (see state.hpp).
struct State {
  double t = 0.0;  ///< t_k = t0 + k h on the grid below (never summed step by step)
  TimeGrid grid;  ///< the grid t is on (time_grid.hpp)
  Vector q;       ///< configuration q_k (n_q entries; rigid bodies: unit quaternions, renormalised every step)
  Vector p;       ///< average momentum p~_k, with mu(q_k) M^-1 p~_k = 0 (n_v, as force)
  Vector lambda;  ///< multipliers lambda~_k (sign convention M qdd = f + mu^T lambda)
  Vector force;   ///< f(t_k, q_k) + mu(q_k)^T lambda~_k
  long steps = 0;     ///< steps taken since the start (schedules restarts and measurements)
  long restarts = 0;  ///< multiplier restarts since the start (RattleOptions::restart)
  ModeWatch watch;    ///< when the period-2 mode is measured next (restart_options.hpp)
  /// Composed steps (RattleOptions::order 4, 6) without external forces: the energy
  /// (1/2) p~^T M^-1 p~ + V(q) that every composed step restores. NaN until the first composed
  /// step sets it from the state; set it to NaN again after changing the state by hand.
  double target_energy = std::numeric_limits<double>::quiet_NaN();

  /// The post-momentum leaving t_k, p_{k+1/2} = p~_k + (h/2) force, and the one arriving,
  /// p_{k-1/2} = p~_k - (h/2) force (both exact identities of the scheme).
  ///@{
  Vector post_momentum(double h) const { return p + 0.5 * h * force; }
  Vector pre_momentum(double h) const { return p - 0.5 * h * force; }
  ///@}
};

}  // namespace nonholo
