// The period-2 mode's measurement right after a fused step of a chain of knife edges
// (ElementSet::knife_chain, the single sleigh): C is diagonal and the sweep left its
// reciprocal pivots in the band and sin/cos of q in chain_sincos, so lambda_s and the
// amplitude take one pass over the bodies. The same values, operation for operation, as
// continuous_multiplier_at + parasitic_of (restart.cpp), which go through mu, the bias, mu M^-1 f,
// a solve and mu^T: on a small model their calls cost more than its whole step.
#include <cmath>
#include <limits>

#include "chain_sweep.hpp"
#include "element_set.hpp"

namespace nonholo::detail {

bool knife_chain_parasitic(const Model& model, Workspace& ws, ConstVecRef p, ConstVecRef lambda, double h,
                           double& amplitude) {
  const ElementSet& set = *model.element_set();
  const int n_bodies = static_cast<int>(set.chain.size());
  sparse::BandedLdlt& band = *ws.banded();
  const bool forced = model.has_applied_force();
  const double* sc = ws.chain_sincos.data();
  const double* pp = p.data();
  const double* fa = ws.applied.data();
  const double* lam = lambda.data();
  double* v = ws.velocity.data();     // M^-1 p, as continuous_multiplier_at leaves it
  double* ls = ws.lambda_s.data();
  double* diff = ws.scratch_m.data();  // lambda - lambda_s
  double* g = ws.scratch_n.data();     // mu^T (lambda - lambda_s)
  double* wg = ws.scratch_n2.data();   // M^-1 g
  for (int b = 0; b < n_bodies; ++b) {
    const ChainBody& cb = set.chain[b];
    const double s = sc[2 * b], c = sc[2 * b + 1];
    const double* pb = pp + 3 * b;
    double* vb = v + 3 * b;
    vb[0] = cb.wx * pb[0], vb[1] = cb.wy * pb[1], vb[2] = cb.wt * pb[2];
    double rhs = vb[2] * (c * vb[0] + s * vb[1]);  // the knife edge's bias (chain_bias_from_sincos)
    if (forced) {  // + mu M^-1 f, summed as Model::mu_times does
      const double* f = fa + 3 * b;
      rhs += (s * (cb.wx * f[0]) + -c * (cb.wy * f[1])) + cb.a * (cb.wt * f[2]);
    }
    ls[b] = -rhs * band.row(b)[0];  // the band's diagonal holds 1 / C_bb (BandedLdlt::solve)
    diff[b] = lam[b] - ls[b];
    double* gb = g + 3 * b;
    double* wgb = wg + 3 * b;
    gb[0] = s * diff[b], gb[1] = -c * diff[b], gb[2] = cb.a * diff[b];
    wgb[0] = cb.wx * gb[0], wgb[1] = cb.wy * gb[1], wgb[2] = cb.wt * gb[2];
  }
  if (!std::isfinite(ws.lambda_s.sum())) return false;  // the general path reports it
  const double mode = ws.scratch_n.dot(ws.scratch_n2);
  const double momentum = p.dot(ws.velocity);
  if (!(momentum > 0.0))
    amplitude = mode > 0.0 ? std::numeric_limits<double>::infinity() : 0.0;
  else
    amplitude = 0.5 * h * std::sqrt(mode / momentum);
  return true;
}

}  // namespace nonholo::detail
