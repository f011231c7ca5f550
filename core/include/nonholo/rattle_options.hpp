#pragma once
/// @file
/// The options of the explicit step (rattle.hpp), apart so that the Workspace can remember the
/// last options a step found valid.
#include <nonholo/composition.hpp>
#include <nonholo/restart_options.hpp>

#include <string>

namespace nonholo {

/// @enum HitchMode
/// How the model's holonomic constraints (hitches, docs/design.md §4) are treated:
/// @var HitchMode::OneForm
///   their gradient rows are plain one-forms (the paper's method: the
///   post-momentum energy is exact for f = 0, the gap |g| drifts slowly);
/// @var HitchMode::Holonomic
///   as RATTLE does: the first half kick gets a correction mu_k^T dlambda that
///   puts g(q_{k+1}) = 0 while keeping the other one-forms' averages exact
///   (simplified Newton with the factorisation of C(q_k) the previous step left),
///   and the gradient rows join mu in the second half kick as usual.
enum class HitchMode { OneForm, Holonomic };
const char* to_string(HitchMode mode);  ///< "oneform", "holonomic"
/// Throws std::invalid_argument naming the valid choices.
HitchMode hitch_mode_from_string(const std::string& name);

/// @enum RotationLagrangian
/// The discrete Lagrangian of a rigid body's rotation (W = R_k^T R_{k+1}, its Legendre
/// transform solved per body in the drift, README "3-D bodies"):
/// @var RotationLagrangian::MoserVeselov
///   tr((Id - W) J_d) / h, J_d = tr(I)/2 Id - I: the post-momentum energy is
///   exact for any inertia and any constraints (f = 0); no solution once
///   h |Omega| passes about 1 (Status::LegendreNotSolved);
/// @var RotationLagrangian::MoserVeselovF
///   F(l_MV), F(s) = (c/2h) arccos(1 - h s/c)^2, c = tr(I)/3: exact on the free
///   rotation of an isotropic body, the same exact energy, a smaller error
///   constant (5.6x on the Chaplygin ball, 4.9x on the Suslov top);
/// @var RotationLagrangian::Exponential
///   xi^T I xi / 2h, W = exp(hat(xi)) (RATTLie_nonhol's choice): rotation about a
///   principal axis as a planar body turns, but the energy is not exact for a
///   non-isotropic body (it drifts, README "3-D bodies"). For comparison.
enum class RotationLagrangian : unsigned char { MoserVeselov, MoserVeselovF, Exponential };
const char* to_string(RotationLagrangian rotation);  ///< "moser-veselov", "moser-veselov-f", "exponential"
/// Throws std::invalid_argument naming the valid choices.
RotationLagrangian rotation_from_string(const std::string& name);

/// The options of the explicit step (step(), rattle.hpp).
struct RattleOptions {
  double h = 0.01;  ///< time step
  /// Smallest accepted pivot of C relative to its diagonal (squared sine of the angle between
  /// a one-form and the span of the others). Below it the step refuses: nearly dependent
  /// one-forms would make lambda meaningless.
  double min_pivot_ratio = 1e-12;
  HitchMode hitch = HitchMode::Holonomic;  ///< how the holonomic rows are treated
  /// Holonomic mode: iterate until max_j |g_j(q_{k+1})| <= gap_tolerance (raised to
  /// 16 eps max|q| when coordinates are so large that round-off alone exceeds it, but never
  /// beyond gap_tolerance_limit: at |q| ~ 1e19 round-off is 3e4, and a hitch "closed" to that
  /// is no hitch; such a step fails with GapNotConverged and says why) ...
  ///@{
  double gap_tolerance = 1e-12;
  double gap_tolerance_limit = 1e-6;
  ///@}
  /// ... or fail with Status::GapNotConverged after this many corrections.
  int max_gap_iterations = 20;

  /// The period-2 mode: measured at the end of every few steps, restarted when needed.
  RestartOptions restart = {};

  /// 2: the plain step of size h. 4, 6 or 8: one step advances by H = h through a composition
  /// of plain steps (composition.hpp): a palindromic sequence of plain substeps, each with
  /// its own time for the forces. At the composed step's end, the parasitic amplitude is
  /// measured (monitor_every > 0); restart.mode Auto restarts lambda~ <- lambda_s at every
  /// composed step, Periodic every `every` composed steps, Never not at all (the symmetric
  /// composition on (q, p~, lambda~)). A restart without external forces first brings the
  /// energy of p~, (1/2) p~^T M^-1 p~ + V(q), back to State::target_energy by scaling the
  /// part of p~ no momentum map sees (constraints and momentum maps stay exact).
  int order = 2;
  Composition composition = Composition::Auto;  ///< the composition of orders 4, 6 and 8

  /// Models with rigid bodies: the rotation's discrete Lagrangian (see RotationLagrangian).
  RotationLagrangian rotation = RotationLagrangian::MoserVeselov;
};

/// Throws std::invalid_argument with the offending value.
void validate(const RattleOptions& options);

/// Whether every field is equal (a field added to RattleOptions or RestartOptions must join
/// this: step() checks options again only when they differ from the last valid ones).
inline bool same_options(const RattleOptions& a, const RattleOptions& b) {
  const RestartOptions &r = a.restart, &s = b.restart;
  return a.h == b.h && a.min_pivot_ratio == b.min_pivot_ratio && a.hitch == b.hitch &&
         a.gap_tolerance == b.gap_tolerance && a.gap_tolerance_limit == b.gap_tolerance_limit &&
         a.max_gap_iterations == b.max_gap_iterations && r.mode == s.mode && r.every == s.every &&
         r.tolerance == s.tolerance && r.monitor_every == s.monitor_every && a.order == b.order &&
         a.composition == b.composition && a.rotation == b.rotation;
}

}  // namespace nonholo
