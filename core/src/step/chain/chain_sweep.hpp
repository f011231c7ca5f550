#pragma once
// The fused chain step (chain_sweep.cpp): detail::advance hands a chain of elements on the
// banded backend (Workspace::fused) to it.
#include <nonholo/rattle.hpp>

#include "model/element_set.hpp"

#if defined(__SSE__)
#include <xmmintrin.h>
#endif

namespace nonholo::detail {

// Subnormal numbers (|x| < 2.2e-308) flushed to zero during a fused step, and the caller's
// floating-point mode restored after. A long chain set in motion at one end carries motions
// of 1e-310 and below down its length for a long time; each subnormal operation costs about
// a hundred cycles, and they made the step 3 times slower (measured: 375 against 120 ns per
// body-step, 1000 bodies, 5 steps from rest). Flushing changes no value above 1e-308.
// Only for chains long enough to carry them (`on`): switching the mode costs about as much
// as a small model's whole step (measured on the batched single sleigh).
class FlushSubnormals {
 public:
#if defined(__SSE__)
  explicit FlushSubnormals(bool on = true) : on_(on), saved_(on ? _mm_getcsr() : 0u) {
    if (on_) _mm_setcsr(saved_ | 0x8040u);  // FTZ | DAZ
  }
  ~FlushSubnormals() {
    if (on_) _mm_setcsr(saved_);
  }
#else
  explicit FlushSubnormals(bool = true) {}
#endif
  FlushSubnormals(const FlushSubnormals&) = delete;
  FlushSubnormals& operator=(const FlushSubnormals&) = delete;

#if defined(__SSE__)
 private:
  bool on_;
  unsigned saved_;
#endif
};
inline constexpr int kFlushSubnormalsFrom = 16;  // bodies

// mu(q) in ws.mu_values from ws.chain_sincos, for the q of the last fused step (which wrote
// mu itself only in holonomic mode, where the next step's corrections need it).
void chain_one_forms_from_sincos(const Model& model, Workspace& ws);

// The bias (d/dt mu) qdot at the q of ws.chain_sincos (Workspace::sincos_hold).
void chain_bias_from_sincos(const Model& model, const Workspace& ws, ConstVecRef qdot, VecRef bias);

// C(q) = mu M^-1 mu^T factorised into ws.banded() from mu(q) in ws.mu_values, row by row
// from the elements' layout (Workspace::factorize for a chain: no Gram index map).
sparse::FactorStatus factorize_chain(const Model& model, Workspace& ws, double min_pivot_ratio);

// sin and cos of every body's angle at q (2 per body).
void chain_sincos_of(const Model& model, ConstVecRef q, Vector& sincos);

// Holonomic mode on the common chain (ElementSet::hitched_chain): the position iteration's
// corrections C(q_k) dlambda = scale [g(q_{k+1}); 0] in two passes each, with C(q_k)
// factorised in ws.banded() and sin/cos of q_k in ws.chain_sincos_prev.
// chain_gap_forward: the half kick and drift of st into ws.p_half and ws.q_next (rattle.cpp's
// kick_drift, bit for bit), sin/cos of q_next into ws.chain_sincos, the right-hand side (0 on
// the knife rows) forward-substituted into y, max |q_next| into size; returns max |g| (NaN
// when a gap is).
double chain_gap_forward(const Model& model, Workspace& ws, const State& st, double h, double scale, double* y,
                         double& size);
// The forward substitution alone, of a right-hand side chain_correct_backward left in y.
void chain_forward_substitute(Workspace& ws, double* y);
// Back substitution of x into dlambda, p_half += (h/2) mu^T dlambda and q_next += (h^2/2)
// M^-1 mu^T dlambda body by body, then
// sin/cos and the gaps of the corrected q_next: the next right-hand side is left in x (not
// forward-substituted); returns its max |g|.
double chain_correct_backward(const Model& model, Workspace& ws, double* x, double h, double scale);

// The period-2 mode's amplitude at the state the last fused step produced (ws.chain_sincos
// and C factorised are of its q; p and lambda its p~ and lambda~), as restart.cpp's
// continuous_multiplier_at and parasitic_of give it, to round-off, in one pass
// (chain_measure.cpp). It does not compute lambda_s (a restart does); ws.scratch_m is used.
// `from`: the state the step started from, when its gap corrections set the offset (null
// otherwise): their momentum G/2 = (p_half - p~_k - (h/2) force_k) / h enters as a force.
Status chain_measure(const Model& model, Workspace& ws, const double* p, const double* lambda, double h,
                     const State* from, double& amplitude);

// From the state at t_k to ws.q_next, p_next, lambda, force_next (and ws.applied, the applied
// force at t_{k+1}) as detail::advance computes them; C(q_{k+1}) factorised and mu(q_{k+1})
// in ws.mu_values in holonomic mode (else filled when asked for, Workspace::evaluate_one_forms);
// ws.step_diagnostics filled (its q and steps are set by the caller on commit).
// `kicked`: ws.p_half and ws.q_next already hold the first half kick and drift (holonomic
// mode after enforce_gaps; on the common chain, ws.chain_sincos then holds their sin/cos).
// `check` accumulates q, p and force (non-finite when they are).
// Never throws (thrust callbacks are guarded by the caller); the state is not touched.
Status chain_sweep(const Model& model, Workspace& ws, const State& state, const RattleOptions& options, double h,
                   double t_next, bool kicked, double& check);

// Whether chain_sweep takes the one-sweep path of a chain of knife edges (C diagonal).
inline bool knife_sweep(const Model& model, Workspace& ws, bool kicked) {
  return model.element_set()->knife_chain && ws.banded()->bandwidth() == 0 && !kicked;
}

// Right after a knife_sweep step, with p and lambda its new p~ and lambda~: the period-2 mode's
// amplitude and ws.lambda_s, ws.velocity as continuous_multiplier_at + parasitic_of give them
// (to round-off, bit for bit for one body; knife_mode.cpp), without mu. False when lambda_s is
// not finite (the general path then reports it).
bool knife_chain_parasitic(const Model& model, Workspace& ws, ConstVecRef p, ConstVecRef lambda, double h,
                           double& amplitude);

}  // namespace nonholo::detail
