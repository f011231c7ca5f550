#pragma once
/// @file
/// What to watch along a trajectory (docs/design.md §2): the energy of the average
/// momentum p~ (not exactly preserved unless D is translation invariant), the energy of the
/// post-momentum (preserved to round-off when f = 0, for any D), the constraint residual of
/// p~, the hitch gaps g(q), and the model's momentum maps.
#include <nonholo/model.hpp>
#include <nonholo/rattle_options.hpp>
#include <nonholo/state.hpp>
#include <nonholo/workspace.hpp>

namespace nonholo {

/// What diagnose() measures at one state.
struct Diagnostics {
  double energy = 0.0;       ///< (1/2) p~^T M^-1 p~ + V(q_k)
  /// (1/2) p^T M^-1 p + (V(q_{k-1}) + V(q_k))/2 for the post-momentum p = p_{k-1/2} of the step
  /// that arrived at t_k (p_{-1/2} at the start: the same energy when f = 0).
  double energy_post = 0.0;
  double residual = 0.0;     ///< max_a |(mu(q_k) M^-1 p~_k)_a|; NaN if mu(q_k) is not finite
  double gap = 0.0;          ///< max_j |g_j(q_k)| over the holonomic constraints (0 if none)
};

/// The Diagnostics of `state`. h is the step size in use. Allocation-free; reuses mu(q_k)
/// when the workspace holds it. After a composed step (RattleOptions::order 4, 6) energy_post
/// means nothing: the composed step has no post-momentum (its multipliers restart), and
/// `nonholo run` reports it as NaN.
Diagnostics diagnose(const Model& model, Workspace& ws, const State& state, double h);
/// The same where rigid bodies and a potential make energy_post need q_{k-1}, reached back through
/// the rotation Lagrangian's Legendre transforms: the 4-argument form uses the one of the last
/// options step() accepted on this workspace (Moser-Veselov before any step); this one is told.
Diagnostics diagnose(const Model& model, Workspace& ws, const State& state, double h, RotationLagrangian rotation);

/// diagnose() for the state the last step() on this workspace returned (the same buffers, not
/// changed since): a fused chain step (Workspace::fused) computed these values in its sweeps,
/// and they are returned at no cost; otherwise diagnose() runs. The values agree with
/// diagnose()'s to round-off (energy_post is summed from p_{k+1/2} as the step had it).
///@{
Diagnostics diagnose_step(const Model& model, Workspace& ws, const State& state, double h);
Diagnostics diagnose_step(const Model& model, Workspace& ws, const State& state, double h,
                          RotationLagrangian rotation);
///@}

/// (1/2) p^T M^-1 p. scratch: n entries.
double kinetic_energy(const Model& model, ConstVecRef p, VecRef scratch);

/// The power of the external forces F(t_k, q_k)^T M^-1 p~_k (0 without them). Summed times h
/// over the steps it is the work of the discrete work-energy identity of docs/design.md §8:
/// E_post(k+1/2) - E_post(k-1/2) = h f_k^T M^-1 p~_k. Allocation-free.
double external_power(const Model& model, Workspace& ws, const State& state);

/// out[i] = J_i(q_k, p~_k) for the model's momentum maps, in declaration order. For a
/// horizontal symmetry xi, `<p~_k, xi_Q(q_k)>` is the paper's discrete nonholonomic momentum.
void evaluate_momentum_maps(const Model& model, const State& state, VecRef out);

}  // namespace nonholo
