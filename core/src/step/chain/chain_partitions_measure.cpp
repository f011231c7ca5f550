// The period-2 mode's measurement (chain_measure.cpp) after a partitioned step: each thread
// builds r = C d for its partition's rows (r = mu M^-1 (mu^T lambda~ + f) + bias, no solve) and
// forward-substitutes it with the partitioned factorisation, summing y^2 / D over its rows;
// one thread adds the separators' part, z^T D'^-1 z over the reduced system's forward
// elimination, so that |d|_C^2 = r^T C^-1 r whatever the partitions.
#include <cmath>
#include <limits>

#include "base/thread_team.hpp"
#include "step/chain/chain_partitions.hpp"
#include "step/chain/chain_rows.hpp"
#include "step/chain/chain_sweep.hpp"
#include "step/restart_internal.hpp"

namespace nonholo::detail {
namespace {

void measure_part(const Model& model, Workspace& ws, int j, const double* p, const double* lambda, double h,
                  const State* from, ChainPartitions::Part& out) {
  ChainPartitions& cp = *ws.partitions();
  const ChainBodies body = model.element_set()->chain_bodies();
  const int n_bodies = body.size();
  sparse::BandedLdlt& band = *ws.banded();
  const PartRows rows(band, cp, j, n_bodies);
  const bool tail = is_tail(cp, j);
  const double* sc = ws.chain_sincos.data();
  const double* fa = model.has_applied_force() ? ws.applied.data() : nullptr;
  double* y = ws.scratch_m.data();
  auto next_sc = [&](int b) { return b + 1 < n_bodies ? sc + 2 * b + 2 : sc + 2 * b; };
  const double* ph = ws.p_half.data();
  const double *p_from = from ? from->p.data() : nullptr, *f_from = from ? from->force.data() : nullptr;
  auto gap_half = [&](int i) { return (ph[i] - p_from[i] - 0.5 * h * f_from[i]) / h; };

  Group groups[2];
  double z[2][3], v[2][3];
  // Body c: z = M^-1 (mu^T lambda + f (+ G/2)) and v = M^-1 p from g = mu^T lambda on it; its
  // shares of the sums when it is this partition's (`own`; body b1 is the next one's).
  auto enter = [&](int c, const double* g, bool own) {
    const double* w = &body[c].wx;
    for (int k = 0; k < 3; ++k) {
      const double pk = p[3 * c + k], fk = fa ? fa[3 * c + k] : 0.0;
      double gk = g[k] + fk;
      if (from) gk += gap_half(3 * c + k);
      z[c & 1][k] = w[k] * gk;
      v[c & 1][k] = w[k] * pk;
      if (!own) continue;
      const double pm = pk - 0.5 * h * (g[k] + fk);
      out.arriving += pm * (w[k] * pm);
      out.kicks += g[k] * (w[k] * g[k]) + fk * (w[k] * fk);
    }
  };
  // mu^T lambda on body c: its own group's u rows and the group before's v rows.
  auto load = [&](int c) {
    Group& gc = groups[c & 1];
    group_rows(body[c], sc + 2 * c, next_sc(c), gc, nullptr);
    double mt[3] = {0.0, 0.0, 0.0};
    for (int i = 0; i < gc.rows; ++i)
      for (int k = 0; k < 3; ++k) mt[k] += gc.u[i][k] * lambda[3 * c + i];
    if (c > 0) {
      Group before;
      group_rows(body[c - 1], sc + 2 * c - 2, sc + 2 * c, before, nullptr);
      for (int i = 0; i < before.rows; ++i)
        for (int k = 0; k < 3; ++k) mt[k] += before.v[i][k] * lambda[3 * (c - 1) + i];
    }
    enter(c, mt, c < rows.b1);
  };
  load(rows.b0);
  for (int b = rows.b0; b < rows.b1; ++b) {
    const bool last_body = b + 1 == n_bodies;
    if (!last_body) load(b + 1);
    const Group& g = groups[b & 1];
    const double* zn = last_body ? z[b & 1] : z[(b + 1) & 1];
    double bias[3];
    group_bias(body[b], sc + 2 * b, next_sc(b), v[b & 1], last_body ? v[b & 1] : v[(b + 1) & 1], bias);
    const int r = 3 * b;
    for (int i = 0; i < g.rows; ++i) y[r + i] = dot3(g.u[i], z[b & 1]) + dot3(g.v[i], zn) + bias[i];
    if (tail) continue;  // substituted from the chain's end, below
    if (rows.separator(b)) out.right_r[0] = y[r + 1], out.right_r[1] = y[r + 2];
    rows.forward(b, y, out.left_y, out.right_y);
    const int own_rows = rows.hitch_rows(b) ? g.rows : 1;
    for (int i = 0; i < own_rows; ++i) out.mode += y[r + i] * y[r + i] * band.row(r + i)[kChainBandwidth];
  }
  if (tail) {
    forward_tail(cp, n_bodies, y);
    out.mode += tail_mode(cp, n_bodies);
  }
}

}  // namespace

Status chain_measure_parted(const Model& model, Workspace& ws, const double* p, const double* lambda, double h,
                            const State* from, double& amplitude) {
  ChainPartitions& cp = *ws.partitions();
  const int parts = cp.parts;
  ChainPartitions::Part* out = cp.part.data();
  auto job = [&](TeamMember& member) {
    const FlushSubnormals flush;
    const int team = member.size();
    for (int j = member.index(); j < parts; j += team) {
      ChainPartitions::Part& part = out[j];
      part.mode = part.arriving = part.kicks = 0.0;
      part.left_y[0] = part.left_y[1] = 0.0;
      measure_part(model, ws, j, p, lambda, h, from, part);
    }
  };
  ThreadPool::run(ws.team(), job);
  double mode = 0.0, arriving = 0.0, kicks = 0.0;
  for (int j = 0; j < parts; ++j) {
    mode += out[j].mode;
    arriving += out[j].arriving;
    kicks += out[j].kicks;
  }
  // The separators: z = L_S^-1 (r_s - L_sI y_I), then z^T D'^-1 z.
  for (int j = 0; j + 1 < parts; ++j) {
    ChainPartitions::Block& k = cp.block[j];
    for (int a = 0; a < 2; ++a) k.rhs[a] = out[j].right_r[a] - out[j].right_y[a] - out[j + 1].left_y[a];
    if (j > 0) {
      const ChainPartitions::Block& pk = cp.block[j - 1];
      const double* iv = pk.inverse;
      const double z0 = iv[0] * pk.rhs[0] + iv[1] * pk.rhs[1], z1 = iv[1] * pk.rhs[0] + iv[2] * pk.rhs[1];
      k.rhs[0] -= pk.up[0][0] * z0 + pk.up[1][0] * z1;
      k.rhs[1] -= pk.up[0][1] * z0 + pk.up[1][1] * z1;
    }
    const double* iv = k.inverse;
    mode += k.rhs[0] * (iv[0] * k.rhs[0] + iv[1] * k.rhs[1]) + k.rhs[1] * (iv[1] * k.rhs[0] + iv[2] * k.rhs[1]);
  }
  if (!std::isfinite(mode))
    return ws.fail(Status::NonFiniteState,
                   "the continuous multiplier is not finite (the bias or the force is NaN or Inf): "
                   "check the model's bias and forces, or reduce the step size");
  amplitude = parasitic_amplitude_of(mode, arriving, kicks, h);
  return Status::Ok;
}

}  // namespace nonholo::detail
