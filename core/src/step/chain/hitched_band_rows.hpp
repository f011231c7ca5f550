#pragma once
// The common chain's band rows in closed form, as the partitioned step builds them
// (chain_partitions.cpp from the head, chain_partitions_tail.cpp from the tail, which moves
// the same entries to its reversed rows): the same formulas as the one-thread sweep_hitched
// (chain_sweep.cpp).
#include <algorithm>
#include <cmath>

#include <nonholo/sparse/banded_ldlt.hpp>

#include "model/element_set.hpp"

namespace nonholo::detail {

// The knife row of body b, and the hitch
// rows b -> b+1 (`next` null: only the entries on body b's rows, as a separator's own rows
// see them from its partition).
inline void knife_band_row(const ChainBody& cb, double s, double c, double fp, double* row) {
  const double wx = cb.wx, wy = cb.wy, wt = cb.wt, a = cb.a;
  row[0] = row[1] = 0.0;
  row[2] = -wx * s + wt * a * fp * s;
  row[3] = wy * c - wt * a * fp * c;
  row[4] = wx * s * s + wy * c * c + wt * a * a;
}
inline void hitch_band_rows(const ChainBody& cb, const ChainBody* next, double s, double c, double sn, double cn,
                            double fp, double* rx, double* ry) {
  const double wx = cb.wx, wy = cb.wy, wt = cb.wt, a = cb.a, d = cb.d, f = cb.f;
  const double wtd = wt * d;
  rx[0] = 0.0;
  rx[1] = -wx + wtd * fp * s * s;
  rx[2] = -wtd * fp * s * c;
  rx[3] = wx * s + wtd * a * s;
  ry[0] = -wtd * fp * s * c;
  ry[1] = -wy + wtd * fp * c * c;
  ry[2] = -wy * c - wtd * a * c;
  if (next) {
    const double wtnf = next->wt * f;
    rx[4] = wx + wtd * d * s * s + next->wx + wtnf * f * sn * sn;
    ry[3] = -wtd * d * s * c - wtnf * f * sn * cn;
    ry[4] = wy + wtd * d * c * c + next->wy + wtnf * f * cn * cn;
  } else {
    rx[4] = ry[3] = ry[4] = 0.0;
  }
}
// The hitch b -> b+1's right-hand side -(2/h) mu v^ (v: body b, vn: body b+1).
inline void hitch_rhs(const ChainBody& cb, const double* sc, const double* v, const double* vn, double scale,
                      double* out) {
  const double s = sc[0], c = sc[1], sn = sc[2], cn = sc[3];
  out[0] = scale * (v[0] + cb.d * s * v[2] - vn[0] + cb.f * sn * vn[2]);
  out[1] = scale * (v[1] - cb.d * c * v[2] - vn[1] - cb.f * cn * vn[2]);
}
inline void hitch_gap(const ChainBody& cb, const double* qb, const double* sc, double& gap) {
  gap = std::max(gap, std::abs(qb[0] - cb.d * sc[1] - qb[3] - cb.f * sc[3]));
  gap = std::max(gap, std::abs(qb[1] - cb.d * sc[0] - qb[4] - cb.f * sc[2]));
}
inline void hitch_residual(const ChainBody& cb, const double* sc, const double* v, const double* vn,
                           double& residual) {
  residual = std::max(residual, std::abs(v[0] + cb.d * sc[0] * v[2] - vn[0] + cb.f * sc[2] * vn[2]));
  residual = std::max(residual, std::abs(v[1] - cb.d * sc[1] * v[2] - vn[1] - cb.f * sc[3] * vn[2]));
}


// A separator's rows (rx, ry: its entries on rows r-2, r-1, r at [1..3] and [0..2]) eliminated
// against the three rows before it in `band` (r = 3b: the knife row of the body that carries
// it): their L in place, their Schur block (xx, xy, yy) in schur, and L D in wx, wy (what a
// border needs).
inline void separator_rows(sparse::BandedLdlt& band, int r, double* rx, double* ry, double* schur, double* wx,
                           double* wy) {
  constexpr int KD = 4;
  double lx[3], ly[3];
  for (int t = 0; t < 3; ++t) {
    const double* l = band.row(r - 2 + t);
    double ax = rx[t + 1], ay = ry[t];
    for (int u = 0; u < t; ++u) {
      ax -= wx[u] * l[KD - (t - u)];
      ay -= wy[u] * l[KD - (t - u)];
    }
    wx[t] = ax, wy[t] = ay;
    lx[t] = ax * l[KD], ly[t] = ay * l[KD];
    rx[t + 1] = lx[t], ry[t] = ly[t];
  }
  schur[0] = schur[1] = schur[2] = 0.0;
  for (int t = 0; t < 3; ++t) schur[0] += wx[t] * lx[t], schur[1] += wx[t] * ly[t], schur[2] += wy[t] * ly[t];
}

}  // namespace nonholo::detail
