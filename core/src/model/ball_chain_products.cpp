// mu x and mu^T lambda of a ball chain (ElementSet::ball_chain), ball by ball from its layout:
// ball b's 12 values at 12 b (rolling x on (Omega_b, xdot_b), rolling y on (Omega_b, ydot_b),
// the rod b -> b+1's [d] on b's centre and [-d] on b+1's), its rows at 3 b, its velocities at
// 5 b. The general products read a column index per value and, for mu^T, zero g first and
// scatter into it: two streams more over the largest arrays of a step. The sums run in the
// pattern's order (rows ascending, columns ascending), so the results are the general ones'.
#include "model/element_set.hpp"

namespace nonholo::detail {

void ElementSet::ball_chain_times(const double* mu, const double* x, double* y) const {
  const int n = static_cast<int>(balls.size());
  for (int b = 0; b < n; ++b) {
    const double* a = mu + 12 * b;
    const double* v = x + 5 * b;
    double* out = y + 3 * b;
    out[0] = a[0] * v[0] + a[1] * v[1] + a[2] * v[2] + a[3] * v[3];
    out[1] = a[4] * v[0] + a[5] * v[1] + a[6] * v[2] + a[7] * v[4];
    if (b + 1 < n) out[2] = a[8] * v[3] + a[9] * v[4] + a[10] * v[8] + a[11] * v[9];
  }
}

void ElementSet::ball_chain_transpose_times(const double* mu, const double* lambda, double* g) const {
  const int n = static_cast<int>(balls.size());
  for (int b = 0; b < n; ++b) {
    ball_chain_transpose_ball(mu + 12 * b, lambda + 3 * b, b > 0, b + 1 < n, g + 5 * b);
  }
}

}  // namespace nonholo::detail
