#pragma once
// Pieces of the implicit general form (implicit.cpp) that its period-2 mode control
// (implicit_restart.cpp) shares.
#include <nonholo/implicit.hpp>

namespace nonholo::detail {

// Dense mu(q) from the pattern into ws.mu (ws.mu_values: the values).
void dense_one_forms(const Model& model, ConstVecRef q, ImplicitWorkspace& ws);
// f = -grad V + F at (t, q) into ws.force.
void applied(const Model& model, double t, ConstVecRef q, ImplicitWorkspace& ws);

// After ws.reflect(q, ...) (M(q), mu(q) and C(q) factorised) and with ws.force = f(t, q): the
// continuous multiplier of the equations with the metric's Christoffel terms,
//   C lambda = -(mu' v) - mu M^-1 (f - Gamma(v)),
// at v = ws.velocity, split into lambda_f (the force's part) and lambda_b (quadratic in v).
// Allocation-free.
Status continuous_multiplier_parts(const Model& model, ImplicitWorkspace& ws, ConstVecRef q);

// After the step's candidate (ws.q_next, ws.p_next = p+, ws.force = f(t_{k+1}, q_{k+1})) is
// complete: measure the period-2 mode when due and restart as options ask, planning the next
// measurement in `watch`. On failure the candidate may be partly changed (not committed).
Status implicit_control_mode(const Model& model, ImplicitWorkspace& ws, const ImplicitState& s,
                             const ImplicitOptions& o, ModeWatch& watch);

}  // namespace nonholo::detail
