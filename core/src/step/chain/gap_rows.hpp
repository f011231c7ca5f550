#pragma once
// Holonomic mode's passes on the common chain, body by body (chain_passes.cpp on one thread,
// chain_partitions_passes.cpp on several): the same operations in both, so that a partition's
// bodies get the bits the one-thread pass gives them.
#include <algorithm>
#include <cmath>

#include "step/chain/chain_rows.hpp"

namespace nonholo::detail {

// The hitch of body b at q (a: body b's q; sin/cos of b and b+1 in sc): its gap (x, y).
inline void hitch_gap_xy(const ChainBody& cb, const double* a, const double* sc, double& gx, double& gy) {
  gx = a[0] - cb.d * sc[1] - a[3] - cb.f * sc[3];
  gy = a[1] - cb.d * sc[0] - a[4] - cb.f * sc[2];
}

// The largest |gap| so far; NaN wins (and stays).
inline void track_worst(double gx, double gy, double& worst) {
  worst = std::max(worst, std::max(std::abs(gx), std::abs(gy)));
  if (!(gx == gx && gy == gy)) worst = gx + gy;
}
inline void merge_worst(double w, double& worst) {
  if (!(w == w))
    worst = w;
  else
    worst = std::max(worst, w);
}

// Half kick with the forces at t_k and drift of body b (rattle.cpp's kick_drift, bit for bit),
// sin/cos of its new angle; the largest |q_next| in `largest`.
inline void kick_drift_body(const ChainBodies& body, int b, const double* q, const double* p, const double* force,
                            double h, double* ph, double* qn, double* sc, double& largest) {
  const double half = 0.5 * h;
  const double* w = &body[b].wx;  // wx, wy, wt are consecutive
  for (int c = 0; c < 3; ++c) {
    const int i = 3 * b + c;
    ph[i] = p[i] + half * force[i];
    qn[i] = q[i] + h * (w[c] * ph[i]);
    largest = std::max(largest, std::abs(qn[i]));
  }
  sin_cos(qn[3 * b + 2], sc + 2 * b);
}

// p_half += (h/2) mu_k^T dlambda and q_next += (h^2/2) M^-1 mu_k^T dlambda on body b, from
// its knife edge [s, -c, a] and hitch rows [1, d s | ...], [1, -d c | ...] and the previous
// hitch's [... | -1, f s], [... | -1, -f c] (group_rows' values, in the same operations);
// so: sin/cos of q_k. The multipliers x = (previous hitch's x, y; knife edge's; hitch's x, y).
inline void correct_body_with(const ChainBodies& body, int b, const double* so, const double (&x)[5], double h,
                              double* ph, double* qn) {
  const int n_bodies = body.size();
  const double half = 0.5 * h, drift = 0.5 * h * h;
  const ChainBody& cb = body[b];
  const double s = so[2 * b], c = so[2 * b + 1];
  const double lk = x[2];
  double g[3] = {s * lk, -c * lk, cb.a * lk};
  if (b + 1 < n_bodies) {
    const double lx = x[3], ly = x[4];
    g[0] += lx;
    g[1] += ly;
    g[2] += (cb.d * s) * lx + (-cb.d * c) * ly;
  }
  if (b > 0) {
    const double f = body[b - 1].f;
    const double px = x[0], py = x[1];
    g[0] -= px;
    g[1] -= py;
    g[2] += (f * s) * px + (-f * c) * py;
  }
  for (int k = 0; k < 3; ++k) {
    ph[3 * b + k] += half * g[k];
    qn[3 * b + k] += drift * (&cb.wx)[k] * g[k];
  }
}
// The same with body b's multipliers in their rows 3b-2 ... 3b+2 of x.
inline void correct_body(const ChainBodies& body, int b, const double* so, const double* x, double h, double* ph,
                         double* qn) {
  const int n_bodies = body.size();
  const double values[5] = {b > 0 ? x[3 * b - 2] : 0.0, b > 0 ? x[3 * b - 1] : 0.0, x[3 * b],
                            b + 1 < n_bodies ? x[3 * b + 1] : 0.0, b + 1 < n_bodies ? x[3 * b + 2] : 0.0};
  correct_body_with(body, b, so, values, h, ph, qn);
}

// Body c corrected (its multipliers all known): then sin/cos of its new angle, and in place of
// its own rows' dlambda, which no substitution reads any more, the next right-hand side: 0 on
// its knife row and, with `hitch` (body c+1 corrected before), scale times the hitch's gap.
inline void correct_and_measure(const ChainBodies& body, int c, bool hitch, const double* so, double h, double scale,
                                double* ph, double* qn, double* sc, double* x, double& worst) {
  correct_body(body, c, so, x, h, ph, qn);
  sin_cos(qn[3 * c + 2], sc + 2 * c);
  x[3 * c] = 0.0;
  if (!hitch) return;
  double gx, gy;
  hitch_gap_xy(body[c], qn + 3 * c, sc + 2 * c, gx, gy);
  track_worst(gx, gy, worst);
  x[3 * c + 1] = scale * gx;
  x[3 * c + 2] = scale * gy;
}

}  // namespace nonholo::detail
