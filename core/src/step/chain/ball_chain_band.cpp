// C = mu M^-1 mu^T of a chain of rolling balls joined by rods, made row by row from mu's values
// and eliminated as it goes (element_set.hpp's ball_chain layout). Ball b touches four rows: the
// rod from ball b-1 (row 3b-1, [-d'] on b's centre), its rolling rows x and y (3b, 3b+1:
// [angular | 1] on (Omega_b, xdot_b)) and the rod to ball b+1 (3b+2, [d] on b's centre). Each
// entry of C is a sum over the balls two rows share of u^T W_b v, W_b ball b's block of M^-1;
// a rod's diagonal is the only entry two balls share. Rows are eliminated in order: the rod
// 3b-1 once ball b has added its part, then ball b's rolling rows.
#include "step/chain/ball_chain_band.hpp"

#include <nonholo/sparse/banded_ldlt.hpp>

#include <algorithm>

#include "model/element_set.hpp"

namespace nonholo::detail {
namespace {

// The entries of C that ball b contributes, between its four rows: the rod before (p), rolling x
// and y, the rod after (r).
struct BallPart {
  double pp, xp, yp, xx, yx, yy, rp, rx, ry, rr;
};

// From ball b's values (x: its 12 values; the rod before's on b, [-d'], at x[-2], x[-1]) and its
// block of M^-1. Diagonal (every ball's block diagonal: w its 5 entries) or a 5 x 5 block.
inline BallPart diagonal_part(const double* x, bool before, bool after, const double* w) {
  const double p0 = before ? x[-2] : 0.0, p1 = before ? x[-1] : 0.0;
  const double d0 = after ? x[8] : 0.0, d1 = after ? x[9] : 0.0;
  BallPart e;
  e.pp = w[3] * p0 * p0 + w[4] * p1 * p1;
  e.xp = w[3] * x[3] * p0;
  e.yp = w[4] * x[7] * p1;
  e.xx = w[0] * x[0] * x[0] + w[1] * x[1] * x[1] + w[2] * x[2] * x[2] + w[3] * x[3] * x[3];
  e.yx = w[0] * x[4] * x[0] + w[1] * x[5] * x[1] + w[2] * x[6] * x[2];
  e.yy = w[0] * x[4] * x[4] + w[1] * x[5] * x[5] + w[2] * x[6] * x[6] + w[4] * x[7] * x[7];
  e.rp = w[3] * d0 * p0 + w[4] * d1 * p1;
  e.rx = w[3] * d0 * x[3];
  e.ry = w[4] * d1 * x[7];
  e.rr = w[3] * d0 * d0 + w[4] * d1 * d1;
  return e;
}

inline BallPart block_part(const double* x, bool before, bool after, const double* w) {
  double u[4][5] = {};  // the four rows on (Omega, xdot, ydot)
  if (before) u[0][3] = x[-2], u[0][4] = x[-1];
  for (int k = 0; k < 3; ++k) u[1][k] = x[k], u[2][k] = x[4 + k];
  u[1][3] = x[3], u[2][4] = x[7];
  if (after) u[3][3] = x[8], u[3][4] = x[9];
  auto dot5 = [](const double* a, const double* b) {
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3] + a[4] * b[4];
  };
  double wu[4][5];
  for (int j = 0; j < 4; ++j)
    for (int k = 0; k < 5; ++k) wu[j][k] = dot5(w + 5 * k, u[j]);  // w row-major, symmetric
  return {dot5(u[0], wu[0]), dot5(u[1], wu[0]), dot5(u[2], wu[0]), dot5(u[1], wu[1]), dot5(u[2], wu[1]),
          dot5(u[2], wu[2]), dot5(u[3], wu[0]), dot5(u[3], wu[1]), dot5(u[3], wu[2]), dot5(u[3], wu[3])};
}

// Ball b's rows of C (its part e) into the band of bandwidth kd, each handed to `eliminate(row)`
// once complete: the rod before (its diagonal completed by b), then rolling x and y; the rod
// after gets b's part and waits for ball b+1's. False when an elimination fails.
template <class Eliminate>
bool ball_rows(sparse::BandedLdlt& band, int kd, int b, bool before, bool after, const BallPart& e,
               Eliminate&& eliminate) {
  // Band row r, every entry (zeros included), its entry (r, c) for c in [r - kd, r] at kd - (r - c).
  auto start = [&](int r) {
    double* a = band.row(r);
    std::fill(a, a + kd + 1, 0.0);
    return a + kd;  // the diagonal: entry (r, r - j) at [-j]
  };
  const int r = 3 * b;
  if (before) {  // the rod r - 1: its diagonal completed by ball b, then eliminated
    band.row(r - 1)[kd] += e.pp;
    if (!eliminate(r - 1)) return false;
  }
  double* cx = start(r);  // rolling x and y: ball b alone
  if (before) cx[-1] = e.xp;
  cx[0] = e.xx;
  if (!eliminate(r)) return false;
  double* cy = start(r + 1);
  if (before) cy[-2] = e.yp;
  cy[-1] = e.yx;
  cy[0] = e.yy;
  if (!eliminate(r + 1)) return false;
  if (after) {  // the rod r + 2: ball b's part now, ball b+1 adds to its diagonal
    double* cr = start(r + 2);
    if (before) cr[-3] = e.rp;
    cr[-2] = e.rx;
    cr[-1] = e.ry;
    cr[0] = e.rr;
  }
  return true;
}

template <int KD>
sparse::FactorStatus factorize_rows(const Model& model, Workspace& ws, double min_pivot_ratio) {
  const sparse::BlockDiagonal& minv = model.inverse_mass();
  const bool diagonal = minv.is_diagonal();
  const int n = model.num_bodies();
  sparse::BandedLdlt& band = *ws.banded();
  const int kd = KD >= 0 ? KD : band.bandwidth();
  const double* mu = ws.mu_values.data();
  auto eliminate = [&](int r) { return band.template eliminate_row<KD>(r, min_pivot_ratio); };
  band.begin_rows();
  for (int b = 0; b < n; ++b) {
    const double* x = mu + 12 * b;
    const bool before = b > 0, after = b + 1 < n;
    const BallPart e = diagonal ? diagonal_part(x, before, after, minv.diagonal() + 5 * b)
                                : block_part(x, before, after, minv.block_data(b));
    if (!ball_rows(band, kd, b, before, after, e, eliminate)) break;
  }
  return band.finish_rows(min_pivot_ratio);
}

}  // namespace

Status ball_chain_kick(const Model& model, Workspace& ws, const double* p_hat, const double* applied, double h,
                       double min_pivot_ratio, double& check) {
  constexpr int KD = 3;
  const ElementSet& set = *model.element_set();
  const sparse::BlockDiagonal& minv = model.inverse_mass();
  const bool diagonal = minv.is_diagonal();
  const int n = model.num_bodies(), m = model.num_one_forms();
  sparse::BandedLdlt& band = *ws.banded();
  const double* q = ws.q_next.data();
  const double* v = ws.velocity.data();
  double* mu = ws.mu_values.data();
  double* y = ws.lambda.data();  // the right-hand side, forward substituted, then lambda
  const double scale = -2.0 / h;
  ws.forget_one_forms();
  double* key = ws.one_form_key();
  // Row r's elimination and forward substitution (solve_fixed's arithmetic); false on a failed pivot.
  auto eliminate = [&](int r, double rhs) {
    if (!band.eliminate_row<KD>(r, min_pivot_ratio)) return false;
    y[r] = rhs * scale;
    if (r < KD)
      band.forward_row<KD>(r, y);
    else
      band.forward_interior_row<KD, 0>(r, y);
    return true;
  };
  band.begin_rows();
  bool ok = true;
  int b = 0;
  for (; ok && b < n; ++b) {  // forward: rows, elimination, forward substitution
    set.ball_chain_values(q, mu, b, b + 1);
    std::copy(q + 6 * b, q + 6 * b + 6, key + 6 * b);
    const double* x = mu + 12 * b;
    const double* vb = v + 5 * b;
    const bool before = b > 0, after = b + 1 < n;
    const BallPart e = diagonal ? diagonal_part(x, before, after, minv.diagonal() + 5 * b)
                                : block_part(x, before, after, minv.block_data(b));
    const int r = 3 * b;
    // The right-hand side of row `row` (mu v: ElementSet::ball_chain_times' sums): the rod before
    // (between balls b-1 and b), rolling x, rolling y.
    auto rows_rhs = [&](int row) {
      if (row == r - 1) {
        const double* xp = x - 12;
        return eliminate(row, xp[8] * vb[-2] + xp[9] * vb[-1] + xp[10] * vb[3] + xp[11] * vb[4]);
      }
      if (row == r) return eliminate(row, x[0] * vb[0] + x[1] * vb[1] + x[2] * vb[2] + x[3] * vb[3]);
      return eliminate(row, x[4] * vb[0] + x[5] * vb[1] + x[6] * vb[2] + x[7] * vb[4]);
    };
    if (!(ok = ball_rows(band, KD, b, before, after, e, rows_rhs))) break;
  }
  const sparse::FactorStatus status = band.finish_rows(min_pivot_ratio);
  if (!ok || status != sparse::FactorStatus::Ok) {
    set.ball_chain_values(q, mu, std::min(b + 1, n), n);  // all of mu, for the report's scan
    return ws.report_factor_failure(status);
  }
  // Backward: lambda row by row from the last; ball c's force and p~ once its rows' and the rod
  // before's multipliers are known (at ball c - 1's rows).
  const double half = 0.5 * h;
  double sum = 0.0;
  auto finish_ball = [&](int c) {
    double g[5];
    ball_chain_transpose_ball(mu + 12 * c, y + 3 * c, c > 0, c + 1 < n, g);
    for (int i = 0; i < 5; ++i) {
      const int k = 5 * c + i;
      ws.p_next[k] = p_hat[k] + half * g[i];
      ws.force_next[k] = applied ? g[i] + applied[k] : g[i];
      sum += ws.p_next[k] + ws.force_next[k];
    }
  };
  for (int r = m - 1; r >= 0; --r) {
    if (r + KD >= m)
      band.backward_row<KD>(r, y);
    else
      band.backward_interior_row<KD, KD>(r, y);
    if (r % 3 == 0) {  // ball r / 3's rows are done: ball r / 3 + 1 has all of its multipliers
      if (r / 3 + 1 < n) finish_ball(r / 3 + 1);
    }
  }
  finish_ball(0);
  ws.one_forms_factorized_at_key(true);
  ws.forget_sincos();
  check += sum + ws.q_next.sum();
  return Status::Ok;
}

bool ball_chain_kick_applies(const Model& model, Workspace& ws) {
  return ws.banded() && model.element_set() && model.element_set()->ball_chain && ws.banded()->bandwidth() == 3;
}

sparse::FactorStatus factorize_ball_chain(const Model& model, Workspace& ws, double min_pivot_ratio) {
  return ws.banded()->bandwidth() == 3 ? factorize_rows<3>(model, ws, min_pivot_ratio)
                                       : factorize_rows<-1>(model, ws, min_pivot_ratio);
}

}  // namespace nonholo::detail
