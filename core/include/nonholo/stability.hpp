#pragma once
/// @file
/// The explicit step's stability limit (README "What nonholo refuses and why"). Störmer-Verlet,
/// and so the reflection step, is stable on an oscillation of frequency omega only while
/// h omega < 2; beyond that the error grows by a factor per step (a spring chain with k = 1e6
/// at h = 0.01 reached a residual of 5e238 and reported success). stiffest_frequency estimates
/// the largest omega of the linearised constrained motion at q: omega^2 = the spectral radius
/// of P M^-1 K P, with K = -df/dq the stiffness of the applied forces (potential and
/// position-dependent forces, by central differences of f) and P the M-orthogonal projector
/// onto the constraint distribution D(q). Power iteration in the M inner product: its ratio
/// |A x|_M / |x|_M never exceeds the spectral radius, so the estimate is a lower bound of the
/// true omega (a step refused on it is certainly unstable) that approaches it from below.
#include <nonholo/composition.hpp>
#include <nonholo/model.hpp>
#include <nonholo/workspace.hpp>

namespace nonholo {

/// What stiffest_frequency() found.
struct StiffnessEstimate {
  double omega = 0.0;  ///< estimated largest frequency (rad per unit time); 0 without applied forces
  int iterations = 0;  ///< power iterations used
  bool converged = false;  ///< the ratio changed by less than the tolerance in the last iteration
  Vector direction;        ///< the last iterate: pass it back in to warm-start a later estimate
};

/// Set-up call (allocates; throws std::invalid_argument when the one-forms are dependent at
/// q). previous: an earlier estimate to warm-start from (its direction), or nullptr.
StiffnessEstimate stiffest_frequency(const Model& model, Workspace& ws, double t, ConstVecRef q,
                                     const StiffnessEstimate* previous = nullptr, int max_iterations = 40,
                                     double tolerance = 1e-3, double min_pivot_ratio = 1e-12);

/// The largest stable step size of the reflection step on an oscillation of frequency omega:
/// 2 / omega at order 2; a composed step of size H (order 4, 6) makes plain substeps of
/// |gamma_i| H / 2, so its limit is taken as 4 / (omega max_i |gamma_i|) (the substeps' own
/// limit; the composition's exact interval differs somewhat). Infinity when omega is 0.
double stability_limit(double omega, int order = 2, Composition composition = Composition::Auto);

}  // namespace nonholo
