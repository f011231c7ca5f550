// The passes of a fused chain step outside its two sweeps: mu and the bias filled from the
// cached sin/cos when a restart or diagnose() asks for them, and holonomic mode's gap
// evaluations and position corrections, one pass over the bodies each.
#include <algorithm>
#include <cmath>

#include "model/element_set.hpp"
#include "step/chain/chain_partitions.hpp"
#include "step/chain/chain_rows.hpp"
#include "step/chain/gap_rows.hpp"
#include "step/chain/chain_sweep.hpp"

namespace nonholo::detail {

void chain_one_forms_from_sincos(const Model& model, Workspace& ws) {
  const ElementSet& set = *model.element_set();
  const ChainBodies body = set.chain_bodies();
  const int n_bodies = body.size();
  const double* sc = ws.chain_sincos.data();
  double* mu = ws.mu_values.data();
  Group g;
  int at = 0;
  for (int b = 0; b < n_bodies; ++b)
    at += group_rows(body[b], sc + 2 * b, b + 1 < n_bodies ? sc + 2 * b + 2 : sc + 2 * b, g, mu + at);
}

namespace {

template <int KD>
sparse::FactorStatus factorize_rows(const ElementSet& set, sparse::BandedLdlt& band, const double* mu,
                                    double min_pivot_ratio) {
  const ChainBodies body = set.chain_bodies();
  const int n_bodies = body.size();
  const int kd = KD >= 0 ? KD : band.bandwidth();
  Group groups[2];  // groups b and b-1, by parity of b
  int first_of[2] = {0, 0};
  int row = 0, value = 0;
  band.begin_rows();
  for (int b = 0; b < n_bodies; ++b) {
    const ChainBody& cb = body[b];
    Group& g = groups[b & 1];
    value += group_from_values(cb, mu + value, g);
    const double* wn = b + 1 < n_bodies ? &body[b + 1].wx : &cb.wx;  // wx, wy, wt are consecutive
    for (int j = 0; j < g.rows; ++j) {
      group_band_row(g, j, row, b > 0 ? &groups[(b + 1) & 1] : nullptr, first_of[(b + 1) & 1], &cb.wx, wn, kd,
                     band.row(row + j));
      if (!band.template eliminate_row<KD>(row + j, min_pivot_ratio)) return band.finish_rows(min_pivot_ratio);
    }
    first_of[b & 1] = row;
    row += g.rows;
  }
  return band.finish_rows(min_pivot_ratio);
}

}  // namespace

void chain_sincos_of(const Model& model, ConstVecRef q, Vector& sincos) {
  const int n_bodies = model.num_bodies();
  for (int b = 0; b < n_bodies; ++b) sin_cos(q[3 * b + 2], sincos.data() + 2 * b);
}

sparse::FactorStatus factorize_chain(const Model& model, Workspace& ws, double min_pivot_ratio) {
  const FlushSubnormals flush(model.num_bodies() >= kFlushSubnormalsFrom);
  const ElementSet& set = *model.element_set();
  sparse::BandedLdlt& band = *ws.banded();
  const double* mu = ws.mu_values.data();
  switch (band.bandwidth()) {
    case 0: return factorize_rows<0>(set, band, mu, min_pivot_ratio);
    case 4: return factorize_rows<4>(set, band, mu, min_pivot_ratio);
    default: return factorize_rows<-1>(set, band, mu, min_pivot_ratio);
  }
}

void chain_bias_from_sincos(const Model& model, const Workspace& ws, ConstVecRef qdot, VecRef bias) {
  const ElementSet& set = *model.element_set();
  const ChainBodies body = set.chain_bodies();
  const int n_bodies = body.size();
  const double* sc = ws.chain_sincos.data();
  const double* v = qdot.data();
  double* out = bias.data();
  for (int b = 0, r = 0; b < n_bodies; ++b) {
    const int next = b + 1 < n_bodies ? b + 1 : b;
    r += group_bias(body[b], sc + 2 * b, sc + 2 * next, v + 3 * b, v + 3 * next, out + r);
  }
}

// The common chain's rows: body b has rows 3b (knife edge), 3b+1, 3b+2 (hitch b -> b+1; the
// last body only its knife edge). Their band entries before column LO = 2, 1, 0 and their
// column's entries below row r + HI = 2, 4, 3 are structural zeros (chain_sweep.cpp's
// sweep_hitched): the substitutions skip them, with constant loop bounds inside the band.
namespace {

template <int LO>
inline void forward_hitched(sparse::BandedLdlt& band, int r, double* y) {
  if (r >= 4)
    band.forward_interior_row<4, LO>(r, y);
  else
    band.forward_row<4>(r, y);
}

template <int HI>
inline void backward_hitched(sparse::BandedLdlt& band, int r, int m, double* x) {
  if (r + 4 < m)
    band.backward_interior_row<4, HI>(r, x);
  else
    band.backward_row<4>(r, x);
}

}  // namespace

double chain_gap_forward(const Model& model, Workspace& ws, const State& st, double h, double scale, double* y,
                         double& size) {
  if (ws.factor_parted()) return chain_gap_forward_parted(model, ws, st, h, scale, y, size);
  const FlushSubnormals flush(model.num_bodies() >= kFlushSubnormalsFrom);
  const ElementSet& set = *model.element_set();
  const ChainBodies body = set.chain_bodies();
  const int n_bodies = body.size();
  const double *q = st.q.data(), *p = st.p.data(), *force = st.force.data();
  double* qn = ws.q_next.data();
  double* ph = ws.p_half.data();
  sparse::BandedLdlt& band = *ws.banded();
  ws.forget_sincos();  // they are q_{k+1}'s from here on
  double* sc = ws.chain_sincos.data();
  double worst = 0.0, largest = 0.0;
  auto kick_drift = [&](int b) { kick_drift_body(body, b, q, p, force, h, ph, qn, sc, largest); };
  kick_drift(0);
  for (int b = 0; b + 1 < n_bodies; ++b) {
    kick_drift(b + 1);
    double gx, gy;
    hitch_gap_xy(body[b], qn + 3 * b, sc + 2 * b, gx, gy);
    track_worst(gx, gy, worst);
    const int r = 3 * b;
    y[r] = 0.0;
    y[r + 1] = scale * gx;
    y[r + 2] = scale * gy;
    forward_hitched<2>(band, r, y);
    forward_hitched<1>(band, r + 1, y);
    forward_hitched<0>(band, r + 2, y);
  }
  const int last = 3 * (n_bodies - 1);
  y[last] = 0.0;
  forward_hitched<2>(band, last, y);
  size = largest;
  return worst;
}

void chain_forward_substitute(Workspace& ws, double* y) {
  if (ws.factor_parted()) return chain_forward_substitute_parted(ws, y);
  sparse::BandedLdlt& band = *ws.banded();
  const int m = band.size();
  for (int r = 0; r < m; r += 3) {
    forward_hitched<2>(band, r, y);
    if (r + 1 < m) {
      forward_hitched<1>(band, r + 1, y);
      forward_hitched<0>(band, r + 2, y);
    }
  }
}

double chain_correct_backward(const Model& model, Workspace& ws, double* x, double h, double scale) {
  if (ws.factor_parted()) return chain_correct_backward_parted(model, ws, x, h, scale);
  const FlushSubnormals flush(model.num_bodies() >= kFlushSubnormalsFrom);
  const ElementSet& set = *model.element_set();
  const ChainBodies body = set.chain_bodies();
  const int n_bodies = body.size();
  sparse::BandedLdlt& band = *ws.banded();
  const int m = band.size();
  const double* so = ws.chain_sincos_prev.data();  // sin/cos of q_k: the rows of mu(q_k)
  double* ph = ws.p_half.data();
  double* qn = ws.q_next.data();
  double* sc = ws.chain_sincos.data();
  double worst = 0.0;
  backward_hitched<2>(band, m - 1, m, x);  // the last body's knife edge
  for (int b = n_bodies - 2; b >= -1; --b) {
    if (b >= 0) {  // group b: dlambda of its rows
      const int r = 3 * b;
      backward_hitched<3>(band, r + 2, m, x);
      backward_hitched<4>(band, r + 1, m, x);
      backward_hitched<2>(band, r, m, x);
    }
    // Body c = b+1 has all its multipliers (groups c and b).
    const int c = b + 1;
    correct_and_measure(body, c, c + 1 < n_bodies, so, h, scale, ph, qn, sc, x, worst);
  }
  return worst;
}

}  // namespace nonholo::detail
