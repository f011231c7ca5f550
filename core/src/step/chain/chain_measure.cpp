// The period-2 mode's measurement (restart.cpp's continuous_multiplier_at and parasitic_of)
// for the state a fused chain step just produced, in one forward pass over the bodies instead
// of some ten passes over mu, C and the state (1.6 fused steps at 10^5 bodies) or of a forward
// and a backward pass (this file until the measurement cost a third of a holonomic step).
//
// With d = lambda~ - lambda_s (+ x, the gap corrections' offset C^-1 mu M^-1 G/2) and C(q) =
// L D L^T, which the sweep left factorised: C lambda_s = -(bias + mu M^-1 f), so r := C d =
// mu M^-1 (mu^T lambda~ + f (+ G/2)) + bias needs no solve, and the mode's norm |d|_C^2 = d^T
// C d = r^T C^-1 r = sum_r y_r^2 / D_r with y = L^-1 r, a forward substitution. Body b+1
// entering: mu^T lambda~ + f (+ G/2) on it (its own group's rows and group b's), times M^-1;
// then group b's rows of r are complete and forward-substituted.
#include <nonholo/rattle.hpp>

#include <cmath>
#include <limits>

#include "model/element_set.hpp"
#include "step/chain/chain_partitions.hpp"
#include "step/chain/chain_rows.hpp"
#include "step/chain/chain_sweep.hpp"
#include "step/restart_internal.hpp"

namespace nonholo::detail {
namespace {

template <int KD>
Status measure(const Model& model, Workspace& ws, const double* p, const double* lambda, double h, const State* from,
               double& amplitude) {
  const ElementSet& set = *model.element_set();
  const ChainBodies body = set.chain_bodies();
  const int n_bodies = body.size();
  sparse::BandedLdlt& band = *ws.banded();
  const int kd = KD >= 0 ? KD : band.bandwidth();
  const double* sc = ws.chain_sincos.data();
  const double* fa = model.has_applied_force() ? ws.applied.data() : nullptr;
  double* y = ws.scratch_m.data();
  auto next_sc = [&](int b) { return b + 1 < n_bodies ? sc + 2 * b + 2 : sc + 2 * b; };
  // The gap corrections' momentum G/2 on coordinate i (gap_momentum_half, restart_internal.hpp).
  const double* ph = ws.p_half.data();
  const double *p_from = from ? from->p.data() : nullptr, *f_from = from ? from->force.data() : nullptr;
  auto gap_half = [&](int i) { return (ph[i] - p_from[i] - 0.5 * h * f_from[i]) / h; };

  Group groups[2];          // groups b and b+1, by parity
  double z[2][3], v[2][3];  // M^-1 (mu^T x + f) and M^-1 p of bodies b and b+1, by parity
  double mode = 0.0, arriving = 0.0, kicks = 0.0;  // parasitic_amplitude_of's sums
  // Body c: z and v from g = mu^T x on it (without f), and its shares of |p_-|^2 and of the
  // kicks |mu^T lambda~|^2 + |f|^2 in M^-1.
  auto enter = [&](int c, const double* g) {
    const double* w = &body[c].wx;  // wx, wy, wt are consecutive
    for (int k = 0; k < 3; ++k) {
      const double pk = p[3 * c + k], fk = fa ? fa[3 * c + k] : 0.0;
      const double pm = pk - 0.5 * h * (g[k] + fk);
      double gk = g[k] + fk;
      if (from) gk += gap_half(3 * c + k);
      z[c & 1][k] = w[k] * gk;
      v[c & 1][k] = w[k] * pk;
      arriving += pm * (w[k] * pm);
      kicks += g[k] * (w[k] * g[k]) + fk * (w[k] * fk);
    }
  };
  group_rows(body[0], sc, next_sc(0), groups[0], nullptr);
  {
    double g[3] = {0.0, 0.0, 0.0};
    for (int j = 0; j < groups[0].rows; ++j)
      for (int k = 0; k < 3; ++k) g[k] += groups[0].u[j][k] * lambda[j];
    enter(0, g);
  }
  int row = 0;
  for (int b = 0; b < n_bodies; ++b) {
    const Group& g = groups[b & 1];
    const int next_row = row + g.rows;
    const bool last = b + 1 == n_bodies;
    if (!last) {  // body b+1 enters: its group's u rows and group b's v rows
      Group& gn = groups[(b + 1) & 1];
      group_rows(body[b + 1], sc + 2 * b + 2, next_sc(b + 1), gn, nullptr);
      double mt[3] = {0.0, 0.0, 0.0};
      for (int j = 0; j < gn.rows; ++j)
        for (int k = 0; k < 3; ++k) mt[k] += gn.u[j][k] * lambda[next_row + j];
      for (int j = 0; j < g.rows; ++j)
        for (int k = 0; k < 3; ++k) mt[k] += g.v[j][k] * lambda[row + j];
      enter(b + 1, mt);
    }
    const double* zn = last ? z[b & 1] : z[(b + 1) & 1];  // the last group's v rows are zero
    double bias[3];
    group_bias(body[b], sc + 2 * b, next_sc(b), v[b & 1], last ? v[b & 1] : v[(b + 1) & 1], bias);
    for (int j = 0; j < g.rows; ++j) {
      const int r = row + j;
      y[r] = dot3(g.u[j], z[b & 1]) + dot3(g.v[j], zn) + bias[j];
      band.template forward_row<KD>(r, y);
      mode += y[r] * y[r] * band.row(r)[kd];  // the band's diagonal holds 1 / D
    }
    row = next_row;
  }

  if (!std::isfinite(mode))
    return ws.fail(Status::NonFiniteState,
                   "the continuous multiplier is not finite (the bias or the force is NaN or Inf): "
                   "check the model's bias and forces, or reduce the step size");
  amplitude = parasitic_amplitude_of(mode, arriving, kicks, h);
  return Status::Ok;
}

}  // namespace

Status chain_measure(const Model& model, Workspace& ws, const double* p, const double* lambda, double h,
                     const State* from, double& amplitude) {
  if (ws.factor_parted()) return chain_measure_parted(model, ws, p, lambda, h, from, amplitude);
  const FlushSubnormals flush(model.num_bodies() >= kFlushSubnormalsFrom);
  switch (ws.banded()->bandwidth()) {
    case 0: return measure<0>(model, ws, p, lambda, h, from, amplitude);
    case 4: return measure<4>(model, ws, p, lambda, h, from, amplitude);
    default: return measure<-1>(model, ws, p, lambda, h, from, amplitude);
  }
}

}  // namespace nonholo::detail
