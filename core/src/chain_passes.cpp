// The passes of a fused chain step outside its two sweeps: mu and the bias filled from the
// cached sin/cos when a restart or diagnose() asks for them, and holonomic mode's gap
// evaluations and position corrections, one pass over the bodies each.
#include <algorithm>
#include <cmath>

#include "chain_rows.hpp"
#include "chain_sweep.hpp"
#include "element_set.hpp"

namespace nonholo::detail {

void chain_one_forms_from_sincos(const Model& model, Workspace& ws) {
  const ElementSet& set = *model.element_set();
  const int n_bodies = static_cast<int>(set.chain.size());
  const double* sc = ws.chain_sincos.data();
  double* mu = ws.mu_values.data();
  Group g;
  int at = 0;
  for (int b = 0; b < n_bodies; ++b)
    at += group_rows(set.chain[b], sc + 2 * b, b + 1 < n_bodies ? sc + 2 * b + 2 : sc + 2 * b, g, mu + at);
}

namespace {

template <int KD>
sparse::FactorStatus factorize_rows(const ElementSet& set, sparse::BandedLdlt& band, const double* mu,
                                    double min_pivot_ratio) {
  const int n_bodies = static_cast<int>(set.chain.size());
  const int kd = KD >= 0 ? KD : band.bandwidth();
  Group groups[2];  // groups b and b-1, by parity of b
  int first_of[2] = {0, 0};
  int row = 0, value = 0;
  band.begin_rows();
  for (int b = 0; b < n_bodies; ++b) {
    const ChainBody& cb = set.chain[b];
    Group& g = groups[b & 1];
    value += group_from_values(cb, mu + value, g);
    const double* wn = b + 1 < n_bodies ? &set.chain[b + 1].wx : &cb.wx;  // wx, wy, wt are consecutive
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
  // Knife edge: w (c x' + s y'); hitch x: d c w^2 + f c' w'^2; hitch y: the same with sines.
  const ElementSet& set = *model.element_set();
  const int n_bodies = static_cast<int>(set.chain.size());
  const double* sc = ws.chain_sincos.data();
  const double* v = qdot.data();
  double* out = bias.data();
  int r = 0;
  for (int b = 0; b < n_bodies; ++b) {
    const ChainBody& cb = set.chain[b];
    const double s = sc[2 * b], c = sc[2 * b + 1], w = v[3 * b + 2];
    if (cb.flags & kChainKnife) out[r++] = w * (c * v[3 * b] + s * v[3 * b + 1]);
    if (cb.flags & kChainHitch) {
      const double sn = sc[2 * b + 2], cn = sc[2 * b + 3], wn = v[3 * b + 5];
      out[r++] = cb.d * c * w * w + cb.f * cn * wn * wn;
      out[r++] = cb.d * s * w * w + cb.f * sn * wn * wn;
    }
  }
}

double chain_gap_rhs(const Model& model, Workspace& ws, double scale) {
  const FlushSubnormals flush(model.num_bodies() >= kFlushSubnormalsFrom);
  const ElementSet& set = *model.element_set();
  const ChainBody* body = set.chain.data();
  const int n_bodies = static_cast<int>(set.chain.size());
  const double* qn = ws.q_next.data();
  ws.forget_sincos();  // they are q_{k+1}'s from here on
  double* sc = ws.chain_sincos.data();
  double* rhs = ws.rhs.data();
  double worst = 0.0;
  sin_cos(qn[2], sc);
  for (int b = 0; b + 1 < n_bodies; ++b) {
    const double* a = qn + 3 * b;
    sin_cos(a[5], sc + 2 * b + 2);
    const ChainBody& cb = body[b];
    const double gx = a[0] - cb.d * sc[2 * b + 1] - a[3] - cb.f * sc[2 * b + 3];
    const double gy = a[1] - cb.d * sc[2 * b] - a[4] - cb.f * sc[2 * b + 2];
    worst = std::max(worst, std::max(std::abs(gx), std::abs(gy)));
    if (!(gx == gx && gy == gy)) worst = gx + gy;  // NaN wins
    rhs[3 * b] = 0.0;
    rhs[3 * b + 1] = scale * gx;
    rhs[3 * b + 2] = scale * gy;
  }
  rhs[3 * (n_bodies - 1)] = 0.0;
  return worst;
}

void chain_gap_correction(const Model& model, Workspace& ws, const double* dl, double h) {
  const FlushSubnormals flush(model.num_bodies() >= kFlushSubnormalsFrom);
  const ElementSet& set = *model.element_set();
  const ChainBody* body = set.chain.data();
  const int n_bodies = static_cast<int>(set.chain.size());
  const double* mu = ws.mu_values.data();
  double* ph = ws.p_half.data();
  double* qn = ws.q_next.data();
  const double half = 0.5 * h, drift = 0.5 * h * h;
  for (int b = 0; b < n_bodies; ++b) {
    // mu^T dlambda on body b: its knife edge [s, -c, a] and hitch rows [1, d s | ...],
    // [1, -d c | ...] (values 11 b ...), the previous hitch's [... | -1, f s] and [... | -1, -f c].
    const double* m = mu + 11 * b;
    const double lk = dl[3 * b];
    double g[3] = {m[0] * lk, m[1] * lk, m[2] * lk};
    if (b + 1 < n_bodies) {
      const double lx = dl[3 * b + 1], ly = dl[3 * b + 2];
      g[0] += m[3] * lx;
      g[1] += m[7] * ly;
      g[2] += m[4] * lx + m[8] * ly;
    }
    if (b > 0) {
      const double* mp = mu + 11 * (b - 1);
      const double px = dl[3 * b - 2], py = dl[3 * b - 1];
      g[0] += mp[5] * px;
      g[1] += mp[9] * py;
      g[2] += mp[6] * px + mp[10] * py;
    }
    const ChainBody& cb = body[b];
    for (int c = 0; c < 3; ++c) {
      ph[3 * b + c] += half * g[c];
      qn[3 * b + c] += drift * (&cb.wx)[c] * g[c];
    }
  }
}

}  // namespace nonholo::detail
