#pragma once
// C of a ball chain (ElementSet::ball_chain) factorised from mu's values row by row, without
// C's pattern or the Gram assembler, and the step's constraint kick fused with it
// (ball_chain_band.cpp).
#include <nonholo/workspace.hpp>

namespace nonholo::detail {

// C(q) = mu M^-1 mu^T from mu(q) in ws.mu_values into ws.banded(), eliminated as its rows are
// made (Workspace::factorize for a ball chain).
sparse::FactorStatus factorize_ball_chain(const Model& model, Workspace& ws, double min_pivot_ratio);

// The step's constraint half kick on a ball chain of two balls or more (kd = 3), in two passes
// over the balls where the general kick (rattle.cpp) makes nine: forward, mu(q_{k+1}) into
// ws.mu_values, C's rows made and eliminated, the right-hand side -(2/h) mu v (v = ws.velocity,
// M^-1 of p_hat) forward substituted, q_{k+1} copied as the one-forms' key; backward, lambda into
// ws.lambda and each ball's mu^T lambda into ws.force_next (plus `applied`, when given) and
// p~ = p_hat + (h/2) mu^T lambda into ws.p_next. The general kick's arithmetic on the band, bit
// for bit. Adds the new state's sum to `check` (non-finite if any entry is). Leaves mu and C
// valid at q_{k+1}, as Workspace::factorize_at would; on a failed pivot, its status and message.
Status ball_chain_kick(const Model& model, Workspace& ws, const double* p_hat, const double* applied, double h,
                       double min_pivot_ratio, double& check);
// Whether the step takes ball_chain_kick: a ball chain of two balls or more on its band.
bool ball_chain_kick_applies(const Model& model, Workspace& ws);

}  // namespace nonholo::detail
