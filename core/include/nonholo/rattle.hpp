#pragma once
// The reflection integrator of Ferraro, Iglesias and Martin de Diego for a constant metric:
// the explicit nonholonomic RATTLE of DESIGN.md section 2, one factorisation of
// C = mu M^-1 mu^T per step. With f = 0 it is exactly p_{k+1/2} = (P - Q)*_{q_k} p_{k-1/2}.
#include <nonholo/model.hpp>
#include <nonholo/state.hpp>
#include <nonholo/status.hpp>
#include <nonholo/workspace.hpp>

#include <string>

namespace nonholo {

// How the model's holonomic constraints (hitches, DESIGN.md section 4) are treated:
//   OneForm    their gradient rows are plain one-forms (the paper's method: the
//              post-momentum energy is exact for f = 0, the gap |g| drifts slowly);
//   Holonomic  as RATTLE does: the first half kick gets a correction mu_k^T dlambda that
//              puts g(q_{k+1}) = 0 while keeping the other one-forms' averages exact
//              (simplified Newton with the factorisation of C(q_k) the previous step left),
//              and the gradient rows join mu in the second half kick as usual.
enum class HitchMode { OneForm, Holonomic };
const char* to_string(HitchMode mode);  // "oneform", "holonomic"
// Throws std::invalid_argument naming the valid choices.
HitchMode hitch_mode_from_string(const std::string& name);

// What the step does about the period-2 mode (DESIGN.md section 8, README "Long runs"): the
// multiplier lambda~ carries, besides its smooth part, a component that flips sign every step
// and grows wherever the continuous motion is attracting; left alone it takes the energy of
// p~ and ruins the trajectory while the post-momentum energy stays exact. A restart replaces
// lambda~ by the continuous multiplier lambda_s(q, p~) and rescales p~ so that the
// post-momentum energy (with f = 0; with forces, the discrete work-energy balance) is
// unchanged, together with every momentum map of the model (restart.hpp).
//   Never     the paper's plain method (the amplitude is still measured and reported);
//   Periodic  restart every restart_every steps;
//   Auto      restart when the measured parasitic amplitude exceeds restart_tolerance.
// (A Robert-Asselin-type filter, lambda~ moved a fraction towards lambda_s every step with the
// same rescale, was measured against Auto and dropped: README, "Long runs".)
enum class RestartMode { Never, Periodic, Auto };
const char* to_string(RestartMode mode);  // "never", "periodic", "auto"

struct RattleOptions {
  double h = 0.01;  // time step
  // Smallest accepted pivot of C relative to its diagonal (squared sine of the angle between
  // a one-form and the span of the others). Below it the step refuses: nearly dependent
  // one-forms would make lambda meaningless.
  double min_pivot_ratio = 1e-12;
  HitchMode hitch = HitchMode::Holonomic;
  // Holonomic mode: iterate until max_j |g_j(q_{k+1})| <= gap_tolerance (raised to
  // 16 eps max|q| when coordinates are so large that round-off alone exceeds it) ...
  double gap_tolerance = 1e-12;
  // ... or fail with Status::GapNotConverged after this many corrections.
  int max_gap_iterations = 20;

  RestartMode restart = RestartMode::Auto;
  int restart_every = 0;  // Periodic: steps between restarts (>= 1)
  // Auto: restart when the parasitic amplitude (h/2) |lambda~ - lambda_s|_C / |p~|_{M^-1}
  // exceeds this; 0 means min(h^3, 1e-3) (h in the model's time unit: the mode's seed after a
  // restart is O((h/tau)^3) for a motion on the time scale tau, so set it for models far from
  // tau ~ 1; the cap keeps the mode's share of the energy, the amplitude squared, below 1e-6).
  double restart_tolerance = 0.0;
  // Measure the amplitude at least every this many steps (0: never; Auto needs >= 1), in every
  // mode (ws.parasitic): every step while it is within a factor 16 of the tolerance or after a
  // restart (the mode can double per step where the motion attracts strongly), the interval
  // doubling up to monitor_every while it stays far below. A measurement costs one bias
  // evaluation, one solve with the factorisation the step already has and one mu^T product:
  // about a step's worth on a small model, 40% of one on a long chain.
  int monitor_every = 8;

  // The tolerance Auto uses: restart_tolerance, or min(h^3, 1e-3) when that is 0.
  double parasitic_tolerance() const {
    return restart_tolerance > 0.0 ? restart_tolerance : (h < 0.1 ? h * h * h : 1e-3);
  }
};

// Throws std::invalid_argument with the offending value.
void validate(const RattleOptions& options);

// Sets options.restart (and restart_every) from "auto", "0" or "never", or a whole number
// K >= 1 (every K steps). Throws std::invalid_argument naming the accepted forms.
void set_restart(RattleOptions& options, const std::string& spec);
// The inverse: "auto", "0" or "K".
std::string restart_spec(const RattleOptions& options);

// One step t_k -> t_k + h, then (as options.restart asks) the measurement of the parasitic
// amplitude and a restart at t_{k+1}. Never throws and never allocates. On failure the state
// is left exactly as it was and ws.message() says why and what would help. On success the
// state's vectors have been swapped with workspace buffers (see State), ws.parasitic holds the
// amplitude measured at t_{k+1} (NaN when not measured) and ws.restarted whether the step
// restarted (then state.restarts was incremented).
Status step(const Model& model, Workspace& ws, State& state, const RattleOptions& options);

}  // namespace nonholo
