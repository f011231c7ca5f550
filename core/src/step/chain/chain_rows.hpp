#pragma once
// The rows of one body of a chain of elements (element_set.hpp's chain layout) from the sin
// and cos of its angle and of the next body's: shared by the fused sweeps (chain_sweep.cpp)
// and the passes around them (chain_passes.cpp).
#include <cmath>

#include "model/element_set.hpp"

namespace nonholo::detail {

// A group's rows restricted to its own body (u) and to the next body (v), each on (x, y,
// theta); at most three rows (knife edge, hitch x, hitch y).
struct Group {
  int rows = 0;
  double u[3][3] = {}, v[3][3] = {};
};

// The rows of body b's group from the sin/cos of b and of b+1; writes their values of mu in
// pattern order at `mu` (when not null) and returns how many values that was.
inline int group_rows(const ChainBody& b, const double* sc, const double* sc_next, Group& g, double* mu) {
  int r = 0, k = 0;
  if (b.flags & kChainKnife) {
    const double s = sc[0], c = sc[1];
    g.u[r][0] = s, g.u[r][1] = -c, g.u[r][2] = b.a;
    g.v[r][0] = g.v[r][1] = g.v[r][2] = 0.0;
    if (mu) mu[0] = s, mu[1] = -c, mu[2] = b.a;
    ++r;
    k += 3;
  }
  if (b.flags & kChainHitch) {
    const double s = sc[0], c = sc[1], sn = sc_next[0], cn = sc_next[1];
    // x row on (x_b, theta_b, x_{b+1}, theta_{b+1}): [1, d s, -1, f s']; y row: [1, -d c, -1, -f c'].
    g.u[r][0] = 1.0, g.u[r][1] = 0.0, g.u[r][2] = b.d * s;
    g.v[r][0] = -1.0, g.v[r][1] = 0.0, g.v[r][2] = b.f * sn;
    g.u[r + 1][0] = 0.0, g.u[r + 1][1] = 1.0, g.u[r + 1][2] = -b.d * c;
    g.v[r + 1][0] = 0.0, g.v[r + 1][1] = -1.0, g.v[r + 1][2] = -b.f * cn;
    if (mu) {
      double* x = mu + k;
      x[0] = 1.0, x[1] = b.d * s, x[2] = -1.0, x[3] = b.f * sn;
      x[4] = 1.0, x[5] = -b.d * c, x[6] = -1.0, x[7] = -b.f * cn;
    }
    r += 2;
    k += 8;
  }
  g.rows = r;
  return k;
}

// The same group read back from mu's values of body b in pattern order (group_rows' layout):
// how a factorisation outside the sweeps (factorize_chain) gets the rows of a mu it is given.
inline int group_from_values(const ChainBody& b, const double* mu, Group& g) {
  int r = 0, k = 0;
  if (b.flags & kChainKnife) {
    g.u[r][0] = mu[0], g.u[r][1] = mu[1], g.u[r][2] = mu[2];
    g.v[r][0] = g.v[r][1] = g.v[r][2] = 0.0;
    ++r;
    k += 3;
  }
  if (b.flags & kChainHitch) {  // x row on (x_b, theta_b, x_{b+1}, theta_{b+1}), y row on the y's
    const double* x = mu + k;
    g.u[r][0] = x[0], g.u[r][1] = 0.0, g.u[r][2] = x[1];
    g.v[r][0] = x[2], g.v[r][1] = 0.0, g.v[r][2] = x[3];
    g.u[r + 1][0] = 0.0, g.u[r + 1][1] = x[4], g.u[r + 1][2] = x[5];
    g.v[r + 1][0] = 0.0, g.v[r + 1][1] = x[6], g.v[r + 1][2] = x[7];
    r += 2;
    k += 8;
  }
  g.rows = r;
  return k;
}

inline double dot3w(const double* a, const double* w, const double* b) {
  return a[0] * w[0] * b[0] + a[1] * w[1] * b[1] + a[2] * w[2] * b[2];
}
inline double dot3(const double* a, const double* b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }

// Band row `a` (kd + 1 entries, the diagonal last) of C = mu M^-1 mu^T for row j of group g,
// whose rows start at `first`: entries with the group's own rows (on body b, weights w, and on
// body b+1, weights wn) and with the rows of the group before it (from prev_first; only its v
// part, on body b, meets g: `prev` null for the first group). Every entry, zeros included.
inline void group_band_row(const Group& g, int j, int first, const Group* prev, int prev_first, const double* w,
                           const double* wn, int kd, double* a) {
  const int r = first + j;
  const double uw[3] = {g.u[j][0] * w[0], g.u[j][1] * w[1], g.u[j][2] * w[2]};
  for (int t = 0; t < kd; ++t) {
    const int s = r - kd + t;
    double value = 0.0;
    if (s >= first)
      value = dot3(uw, g.u[s - first]) + dot3w(g.v[j], wn, g.v[s - first]);
    else if (prev && s >= prev_first)
      value = dot3(uw, prev->v[s - prev_first]);
    a[t] = value;
  }
  a[kd] = dot3(uw, g.u[j]) + dot3w(g.v[j], wn, g.v[j]);
}

// The bias (d/dt mu) v of body b's group from sin/cos (sc: body b, sn: body b+1) and the
// velocities of b and b+1 (knife edge: w (c x' + s y'); hitch x: d c w^2 + f c' w'^2; hitch y:
// the same with sines); returns the number of rows.
inline int group_bias(const ChainBody& cb, const double* sc, const double* sn, const double* v, const double* vn,
                      double* out) {
  int r = 0;
  const double s = sc[0], c = sc[1], w = v[2];
  if (cb.flags & kChainKnife) out[r++] = w * (c * v[0] + s * v[1]);
  if (cb.flags & kChainHitch) {
    const double wn = vn[2];
    out[r++] = cb.d * c * w * w + cb.f * sn[1] * wn * wn;
    out[r++] = cb.d * s * w * w + cb.f * sn[0] * wn * wn;
  }
  return r;
}

// sin and cos of one angle in one call (glibc's sincos: about half the cost of both).
inline void sin_cos(double x, double* out) {
#if defined(__GLIBC__)
  ::sincos(x, out, out + 1);
#else
  out[0] = std::sin(x);
  out[1] = std::cos(x);
#endif
}

}  // namespace nonholo::detail
