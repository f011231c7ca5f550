#pragma once
/// @file
/// Continuous-time quantities of docs/design.md §1: the bias term, the M-orthogonal
/// projection onto the annihilator of D, and the multiplier of the index-reduced equations
/// ~~~{.unparsed}
///   C lambda = -(mu' qdot) - mu M^-1 (f + g),
/// ~~~
/// g the gyroscopic force (I Omega) x Omega on each 3-D rigid body's Omega (0 elsewhere), so
/// that M vdot = f + g + mu^T lambda (velocities left-trivialised, nonholo/rigid_body.hpp).
/// Used to start the integrator consistently (start.hpp) and by reference integrators.
#include <nonholo/model.hpp>
#include <nonholo/status.hpp>
#include <nonholo/workspace.hpp>

namespace nonholo {

/// (d/dt mu(q)) qdot: the model's analytic bias, or else a central difference of mu along
/// qdot with step cbrt(eps) (relative accuracy about 1e-10).
Status one_form_bias(const Model& model, Workspace& ws, ConstVecRef q, ConstVecRef qdot, VecRef bias);

/// What the multiplier's right-hand side holds that is quadratic in the velocity: the bias plus
/// mu M^-1 g(qdot) for models with rigid bodies (the bias alone otherwise). Needs mu(q) in the
/// workspace (evaluate_one_forms(q)).
Status constraint_bias(const Model& model, Workspace& ws, ConstVecRef q, ConstVecRef qdot, VecRef bias);

/// p_out = P* p = p - mu^T C^-1 mu M^-1 p at q: the momentum whose velocity lies in D(q) and
/// is M-closest to M^-1 p. p and p_out may alias.
Status project_momentum(const Model& model, Workspace& ws, ConstVecRef q, ConstVecRef p,
                        VecRef p_out, double min_pivot_ratio);

/// out = M^-1 g(v), g the gyroscopic force (I Omega) x Omega on each rigid body's Omega and 0
/// elsewhere (all zero for a model without rigid bodies). Allocation-free.
void gyroscopic_acceleration(const Model& model, ConstVecRef v, VecRef out);

/// The continuous multiplier lambda(t, q, qdot) for a velocity qdot in D(q).
Status constraint_multiplier(const Model& model, Workspace& ws, double t, ConstVecRef q,
                             ConstVecRef qdot, VecRef lambda, double min_pivot_ratio);

}  // namespace nonholo
