#pragma once
// The pieces of restart.hpp that the step calls on its candidate state (workspace buffers)
// before committing it. Preconditions for all three: the workspace holds mu(q) in mu_values
// and the factorisation of C(q); `applied` is f(t, q) when the model has an applied force
// (ignored otherwise). They use ws.velocity, p_half, p_hat, scratch_n, scratch_n2, rhs,
// scratch_m, lambda_s, lambda_f and the map_* buffers as scratch.
#include <nonholo/model.hpp>
#include <nonholo/status.hpp>
#include <nonholo/workspace.hpp>

namespace nonholo::detail {

// ws.lambda_s = lambda_s(q, M^-1 p), the continuous multiplier; leaves ws.velocity = M^-1 p.
Status continuous_multiplier_at(const Model& model, Workspace& ws, ConstVecRef q, ConstVecRef p,
                                ConstVecRef applied);

// In holonomic mode the first half kick uses lambda~_k + dlambda_k (the gap correction), and
// lambda~ settles at the smooth offset lambda_s - dlambda/2 (from lambda~_{k+1} ~ 2 lambda_s -
// lambda~_k - dlambda_k); the period-2 mode is the alternating part about it. gap_offset: use
// the last step's dlambda (ws.gap_multiplier) for that offset.

// (h/2) |lambda - lambda_s + dlambda/2|_C / |p|_{M^-1}, right after continuous_multiplier_at(q, p).
double parasitic_of(const Model& model, Workspace& ws, ConstVecRef p, ConstVecRef lambda, double h,
                    bool gap_offset);

// After continuous_multiplier_at(q, p): lambda <- lambda_s(q, p') (- dlambda/2 with
// gap_offset), with p' the rescale of p that keeps the arriving post-momentum energy (plus the
// averaged potential), and force <- f + mu^T lambda. On failure p, lambda and force are
// unchanged.
Status rescaled_restart(const Model& model, Workspace& ws, ConstVecRef q, VecRef p, VecRef lambda,
                        VecRef force, ConstVecRef applied, double h, bool gap_offset);

}  // namespace nonholo::detail
