// The period-2 mode's measurement right after a fused step of a chain of knife edges
// (ElementSet::knife_chain, the single sleigh): C is diagonal and the sweep left its
// reciprocal pivots in the band and sin/cos of q in chain_sincos, so lambda_s and the
// amplitude take one pass over the bodies. The same operations as continuous_multiplier_at +
// parasitic_of (restart.cpp), which go through mu, the bias, mu M^-1 f, a solve and mu^T (on a
// small model their calls cost more than its whole step); only the sums over the bodies run in
// another order.
#include <cmath>
#include <limits>

#include "model/element_set.hpp"
#include "step/chain/chain_sweep.hpp"
#include "step/restart_internal.hpp"

namespace nonholo::detail {

bool knife_chain_parasitic(const Model& model, Workspace& ws, ConstVecRef p, ConstVecRef lambda, double h,
                           double& amplitude) {
  const ElementSet& set = *model.element_set();
  const ChainBodies body = set.chain_bodies();
  const int n_bodies = body.size();
  sparse::BandedLdlt& band = *ws.banded();
  const bool forced = model.has_applied_force();
  const double* sc = ws.chain_sincos.data();
  const double* pp = p.data();
  const double* fa = ws.applied.data();
  const double* lam = lambda.data();
  double* v = ws.velocity.data();  // M^-1 p, as continuous_multiplier_at leaves it
  double* ls = ws.lambda_s.data();
  // Sums in coordinate order: for one body the order of Eigen's reductions in the general path.
  double sum = 0.0, mode = 0.0, arriving = 0.0, kicks = 0.0, forces = 0.0;  // parasitic_amplitude_of's
  for (int b = 0; b < n_bodies; ++b) {
    const ChainBody& cb = body[b];
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
    sum += ls[b];
    // mu^T (lambda - lambda_s) on the body, g, and its M^-1 norm g^T M^-1 g.
    const double diff = lam[b] - ls[b];
    const double g[3] = {s * diff, -c * diff, cb.a * diff};
    mode = ((mode + g[0] * (cb.wx * g[0])) + g[1] * (cb.wy * g[1])) + g[2] * (cb.wt * g[2]);
    // The arriving post-momentum p - (h/2)(mu^T lambda + f) and the kicks (parasitic_of).
    const double k[3] = {s * lam[b], -c * lam[b], cb.a * lam[b]};
    const double* w = &cb.wx;  // wx, wy, wt are consecutive
    for (int i = 0; i < 3; ++i) {
      const double fi = forced ? fa[3 * b + i] : 0.0;
      const double pm = pb[i] - 0.5 * h * (k[i] + fi);
      arriving += pm * (w[i] * pm);
      kicks += k[i] * (w[i] * k[i]);
      forces += fi * (w[i] * fi);
    }
  }
  if (!std::isfinite(sum)) return false;  // the general path reports it
  amplitude = parasitic_amplitude_of(mode, arriving, kicks + forces, h);
  return true;
}

}  // namespace nonholo::detail
