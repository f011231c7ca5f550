#pragma once
/// @file
/// The period-2 mode and its control (docs/design.md §8). The step does all of this by
/// itself as RattleOptions::restart asks; these entry points are for a user who changes a
/// state between steps (a kick, a new parameter) or wants the measurement alone.
#include <nonholo/model.hpp>
#include <nonholo/rattle.hpp>
#include <nonholo/state.hpp>
#include <nonholo/status.hpp>
#include <nonholo/workspace.hpp>

namespace nonholo {

/// The parasitic amplitude (h/2) |lambda~ - lambda_s|_C / |p~|_{M^-1} of a state: the share of
/// the momentum that the period-2 mode carries (exactly 0 after a restart, O(h^3) for a smooth
/// motion, up to 1 when the mode holds the energy). lambda_s is the continuous multiplier at
/// (t, q, M^-1 p~). Factorises C(q) unless the workspace holds it; allocation-free.
Status parasitic_amplitude(const Model& model, Workspace& ws, const State& state, double h,
                           double& amplitude, double min_pivot_ratio = 1e-12);

/// The energy-exact restart: lambda~ <- lambda_s(q, p~') with p~' = p~_J + s p~_r, where p~_J is
/// the part of p~ that the model's momentum maps see (they must be linear in p, as momentum
/// maps are) and s solves the scalar equation that keeps the energy of the arriving
/// post-momentum p~ - (h/2)(f + mu^T lambda~), plus (V(q_{k-1}) + V(q_k))/2 with a potential,
/// unchanged. Where the maps see all of p~ (a single Chaplygin ball) p~ stays and lambda~ <-
/// lambda_F + s^2 lambda_B (lambda_s's ray, scaled to the norm that keeps the energy). With f = 0 that is the invariant of the method; with external forces it keeps the
/// discrete work-energy balance exact. The constraint residual stays at round-off and every
/// momentum map is unchanged (to the last bit when it reads coordinates no one-form touches).
/// Uses the factorisation of C(q) (factorises only when the workspace does not hold it) and
/// allocates nothing: one solve (two with an applied force), and with momentum maps n + 2
/// evaluations of each map (to find its direction) and 2 + (number of maps) more solves. On
/// failure (Status::RestartFailed: no scale keeps the energy, or a momentum map is not linear
/// in p) the state is unchanged.
Status restart(const Model& model, Workspace& ws, State& state, const RattleOptions& options);

}  // namespace nonholo
