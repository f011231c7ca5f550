// The last partition of a chain split over threads, factorised from the chain's tail
// (chain_partitions.hpp). Read backwards, its bodies form a chain of the same kind: reversed
// body k = N-1-b carries body b's knife edge and, as its hitch to k+1, the hitch b-1 -> b with
// both rows negated. So its band has the first partition's shape (no border; its left
// separator at the end of its sweep), in a band of its own order (ChainPartitions::tail, kept in
// the chain's band's last rows, which the split leaves unused). With two
// threads partition 0 works from the head and this one from the tail: one 2x2 system where
// they meet.
#include <algorithm>

#include "step/chain/chain_partitions.hpp"
#include "step/chain/gap_rows.hpp"
#include "step/chain/hitched_band_rows.hpp"

namespace nonholo::detail {

namespace {

constexpr int KD = kChainBandwidth;

// Row rr of the tail's band in the chain's numbering: row 3k is body b = N-1-k's knife edge,
// rows 3k+1, 3k+2 the hitch b-1 -> b's.
int chain_row(int n_bodies, int rr) {
  const int k = rr / 3, t = rr - 3 * k, b = n_bodies - 1 - k;
  return t == 0 ? 3 * b : 3 * b - 3 + t;
}

// x's rows of the tail (and its left separator's: `separator`) into the tail's order, and back.
void gather(const ChainPartitions& cp, int n_bodies, const double* x, double* xr, bool separator) {
  const int n = n_bodies - cp.tail_first;
  for (int k = 0; k < n; ++k) {
    const int b = n_bodies - 1 - k;
    xr[3 * k] = x[3 * b];
    if (k + 1 < n || separator) {
      xr[3 * k + 1] = -x[3 * b - 2];
      xr[3 * k + 2] = -x[3 * b - 1];
    }
  }
}
void scatter(const ChainPartitions& cp, int n_bodies, const double* xr, double* x) {
  const int n = n_bodies - cp.tail_first;
  for (int k = 0; k < n; ++k) {
    const int b = n_bodies - 1 - k;
    x[3 * b] = xr[3 * k];
    if (k + 1 < n) {
      x[3 * b - 2] = -xr[3 * k + 1];
      x[3 * b - 1] = -xr[3 * k + 2];
    }
  }
}

// The pivot tests' rows in the chain's numbering (a failure names the right body).
void renumber(sparse::PivotLog& log, int n_bodies) {
  if (log.min_row >= 0) log.min_row = chain_row(n_bodies, log.min_row);
  if (log.bad_row >= 0) log.bad_row = chain_row(n_bodies, log.bad_row);
}

}  // namespace

void forward_tail(ChainPartitions& cp, int n_bodies, double* x) {
  const int n = n_bodies - cp.tail_first;
  double* xr = cp.tail_x;
  gather(cp, n_bodies, x, xr, false);
  const PartRows rows(*cp.tail, n_bodies, n);
  double right[2] = {0.0, 0.0};
  for (int g = 0; g < n; ++g) rows.forward<true>(g, xr, nullptr, right);
  ChainPartitions::Part& out = cp.part[cp.parts - 1];
  out.left_y[0] = -right[0], out.left_y[1] = -right[1];  // the separator's rows are negated here
  scatter(cp, n_bodies, xr, x);
}

void backward_tail(ChainPartitions& cp, int n_bodies, double* x) {
  const int n = n_bodies - cp.tail_first;
  double* xr = cp.tail_x;
  gather(cp, n_bodies, x, xr, true);
  auto no_border = [](double*, int) {};
  for (int k = n - 1; k >= 0; --k) back_substitute_body(*cp.tail, k, n_bodies, k == n - 1, xr, no_border);
  scatter(cp, n_bodies, xr, x);
}

double tail_mode(const ChainPartitions& cp, int n_bodies) {
  const int own = 3 * (n_bodies - cp.tail_first) - 2;
  const double* xr = cp.tail_x;
  double mode = 0.0;
  for (int r = 0; r < own; ++r) mode += xr[r] * xr[r] * cp.tail->row(r)[KD];
  return mode;
}

// PartSweep<true>::forward (chain_partitions.cpp) from the tail: reversed body k = N-1-b enters
// at i = k, completes at i = k+1 (after body b-1's spring), its group's rows are substituted at
// i = k+2. Every entry of its rows, and every right-hand side, is the one-thread sweep's, by the
// same formulas (the chain's knife and hitch rows, hitched_band_rows.hpp), moved to its place in
// the reversed rows and negated with the hitch rows: C and b are the one-thread step's bit for
// bit, up to exact signs, and only the elimination order differs. The right-hand sides and y in
// tail_x, in the tail's order.
bool tail_sweep_forward(const Model& model, Workspace& ws, const State& st, double h, double t_next, bool kicked,
                        double min_pivot_ratio) {
  ChainPartitions& cp = *ws.partitions();
  sparse::BandedLdlt& band = *cp.tail;
  const ChainBodies body = model.element_set()->chain_bodies();
  const int n_bodies = body.size(), b0 = cp.tail_first, n = n_bodies - b0;
  ChainPartitions::Part& out = cp.part[cp.parts - 1];
  sparse::PivotLog& log = out.pivots;
  Forward fw(model, ws, st, h, t_next, kicked);
  fw.restrict_to(b0, n_bodies);
  fw.thrust_values = cp.thrust_values.data();
  double *qn = fw.qn, *sc = fw.sc, *y = cp.tail_x;
  const double rhs_scale = -2.0 / h;
  double vhat[2][3] = {};
  double gap = 0.0, right[2] = {0.0, 0.0}, work[KD];
  // The hitch b -> b+1's rows in the chain's order (knife_band_row, hitch_band_rows), kept from
  // body b+1 for body b: their entries on body b's knife edge and on the hitch b-1 -> b.
  double hx[5] = {}, hy[5] = {};
  const PartRows rows(band, n_bodies, n);
  bool ok = true;
  for (int i = 0; i <= n + 1 && ok; ++i) {
    if (i < n) fw.enter_reversed(n_bodies - 1 - i, !kicked);
    if (i >= 1 && i <= n) {  // reversed body k complete: p^, v^, its rows eliminated
      const int k = i - 1, b = n_bodies - 1 - k;
      const ChainBody& cb = body[b];
      double* v = vhat[k & 1];
      fw.complete(b, cb, v);
      const int r = 3 * k;
      double knife[5];
      knife_band_row(cb, sc[2 * b], sc[2 * b + 1], body[b - 1].f, knife);  // b >= b0 >= 2
      double* rk = band.row(r);
      rk[0] = rk[1] = 0.0;
      rk[2] = -hx[3], rk[3] = -hy[2];  // against the hitch b -> b+1 (zero at the chain's end)
      rk[4] = knife[4];
      ok = k >= 2 ? band.eliminate_interior_row<KD, 2>(r, min_pivot_ratio, log, work)
                  : band.eliminate_row<KD>(r, min_pivot_ratio, log);
      double* rx = band.row(r + 1);
      double* ry = band.row(r + 2);
      // The hitch b-1 -> b's rows, negated: against the hitch b -> b+1's and body b's knife edge
      // (entries on body b), and the diagonal block.
      rx[0] = 0.0, rx[1] = hx[1], rx[2] = hy[0], rx[3] = -knife[2];
      ry[0] = hx[2], ry[1] = hy[1], ry[2] = -knife[3];
      if (!ok) {
      } else if (k + 1 == n) {  // the separator: its Schur block (negated rows: the same block)
        rx[4] = ry[3] = ry[4] = 0.0;
        double wx[3], wy[3];
        separator_rows(band, r, rx, ry, out.left_schur, wx, wy);
      } else {
        hitch_band_rows(body[b - 1], &cb, sc[2 * b - 2], sc[2 * b - 1], sc[2 * b], sc[2 * b + 1], body[b - 2].f, hx,
                        hy);
        rx[4] = hx[4], ry[3] = hy[3], ry[4] = hy[4];
        hitch_gap(body[b - 1], qn + 3 * b - 3, sc + 2 * b - 2, gap);
        ok = k >= 2 ? band.eliminate_interior_row<KD, 1>(r + 1, min_pivot_ratio, log, work) &&
                          band.eliminate_interior_row<KD, 0>(r + 2, min_pivot_ratio, log, work)
                    : band.eliminate_row<KD>(r + 1, min_pivot_ratio, log) &&
                          band.eliminate_row<KD>(r + 2, min_pivot_ratio, log);
      }
    }
    if (ok && i >= 2) {  // reversed group g: right-hand side and forward substitution
      const int g = i - 2, b = n_bodies - 1 - g;
      const ChainBody& cb = body[b];
      const double* v = vhat[g & 1];
      const int r = 3 * g;
      y[r] = rhs_scale * (sc[2 * b] * v[0] - sc[2 * b + 1] * v[1] + cb.a * v[2]);
      if (g + 1 < n) {  // the hitch b-1 -> b's, negated
        double rhs[2];
        hitch_rhs(body[b - 1], sc + 2 * b - 2, vhat[(g + 1) & 1], v, rhs_scale, rhs);
        y[r + 1] = -rhs[0];
        y[r + 2] = -rhs[1];
      }
      rows.forward<true>(g, y, nullptr, right);
    }
  }
  renumber(log, n_bodies);
  if (!ok) return false;
  out.left_y[0] = -right[0], out.left_y[1] = -right[1];
  out.kinetic_post = fw.kinetic_post;
  out.potential_old = fw.potential_old, out.potential_new = fw.potential_new;
  out.check = fw.check;
  out.gap = gap;
  return true;
}

// PartSweep<true>::backward from the tail: the rows back-substituted from the separator's end
// (the chain's order: bodies b0, b0+1, ...), each multiplier written back in the chain's
// numbering, each body finished once its later hitch is known.
void tail_sweep_backward(const Model& model, Workspace& ws, double h) {
  ChainPartitions& cp = *ws.partitions();
  const ChainBodies body = model.element_set()->chain_bodies();
  const int n_bodies = body.size(), b0 = cp.tail_first, n = n_bodies - b0;
  ChainPartitions::Part& out = cp.part[cp.parts - 1];
  const double half = 0.5 * h;
  const double* sc = ws.chain_sincos.data();
  const double* forces = model.has_applied_force() ? ws.applied.data() : nullptr;
  double *pn = ws.p_next.data(), *fn = ws.force_next.data(), *lam = ws.lambda.data(), *x = cp.tail_x;
  x[3 * n - 2] = -lam[3 * b0 - 2];  // the separator's multipliers, negated here
  x[3 * n - 1] = -lam[3 * b0 - 1];
  BlockSum kinetic;
  double residual = 0.0, check = 0.0, before[3] = {0.0, 0.0, 0.0};
  auto finish_body = [&](int c) {
    double v[3];
    residual = std::max(residual, finish_hitched_body(body, c, sc, lam, half, forces, pn, fn, kinetic, check, v));
    if (c > b0) hitch_residual(body[c - 1], sc + 2 * c - 2, before, v, residual);  // the separator's: after the join
    before[0] = v[0], before[1] = v[1], before[2] = v[2];
  };
  auto no_border = [](double*, int) {};
  for (int k = n - 1; k >= 0; --k) {
    back_substitute_body(*cp.tail, k, n_bodies, k == n - 1, x, no_border);
    const int b = n_bodies - 1 - k;
    lam[3 * b] = x[3 * k];
    if (k + 1 < n) {
      lam[3 * b - 2] = -x[3 * k + 1];
      lam[3 * b - 1] = -x[3 * k + 2];
    }
    if (b > b0) finish_body(b - 1);
  }
  finish_body(n_bodies - 1);
  out.kinetic = kinetic;
  out.residual = residual;
  out.check += check;
}

// Holonomic mode's passes on the tail (chain_partitions_passes.cpp's work on a partition,
// body by body in the same operations), in its order: its rows of the passes' vector stay in
// tail_x from the gaps' pass to the last correction (the chain's x never holds them).
void tail_gap_forward(const ChainBodies& body, ChainPartitions& cp, const double* q, const double* p,
                      const double* force, double h, double scale, double* ph, double* qn, double* sc, double& worst,
                      double& largest) {
  const int n_bodies = body.size(), n = n_bodies - cp.tail_first;
  double* y = cp.tail_x;
  const PartRows rows(*cp.tail, n_bodies, n);
  double right[2] = {0.0, 0.0};
  // Bodies are drifted two ahead of the gaps that read them: a gap read right after the
  // drift's stores stalled on them (store forwarding; the pass took three times as long on the
  // AMD machine with the gap read at once, and still stalled one ahead).
  constexpr int kAhead = 2;
  for (int k = 0; k < std::min(kAhead, n); ++k)
    kick_drift_body(body, n_bodies - 1 - k, q, p, force, h, ph, qn, sc, largest);
  for (int k = 0; k < n; ++k) {
    const int b = n_bodies - 1 - k;
    y[3 * k] = 0.0;
    if (k + kAhead < n) kick_drift_body(body, b - kAhead, q, p, force, h, ph, qn, sc, largest);
    if (k + 1 < n) {  // the hitch b-1 -> b, negated (the last one is the separator's)
      double gx, gy;
      hitch_gap_xy(body[b - 1], qn + 3 * b - 3, sc + 2 * b - 2, gx, gy);
      track_worst(gx, gy, worst);
      y[3 * k + 1] = -(scale * gx);
      y[3 * k + 2] = -(scale * gy);
    }
    rows.forward<true>(k, y, nullptr, right);
  }
  ChainPartitions::Part& out = cp.part[cp.parts - 1];
  out.left_y[0] = -right[0], out.left_y[1] = -right[1];
}

void tail_forward_substitute(ChainPartitions& cp, int n_bodies) {
  const int n = n_bodies - cp.tail_first;
  double* y = cp.tail_x;
  const PartRows rows(*cp.tail, n_bodies, n);
  double right[2] = {0.0, 0.0};
  for (int k = 0; k < n; ++k) rows.forward<true>(k, y, nullptr, right);
  ChainPartitions::Part& out = cp.part[cp.parts - 1];
  out.left_y[0] = -right[0], out.left_y[1] = -right[1];
}

// Back substitution from the separator's end (bodies b0, b0+1, ...): body c is corrected once
// its later hitch's multipliers are known, then the gap of the hitch c-1 -> c (both corrected)
// and c's knife edge's 0 take the rows no substitution reads any more.
void tail_correct_backward(const ChainBodies& body, ChainPartitions& cp, const double* so, double h, double scale,
                           double* ph, double* qn, double* sc, const double* x, double& worst) {
  const int n_bodies = body.size(), b0 = cp.tail_first, n = n_bodies - b0;
  double* y = cp.tail_x;
  y[3 * n - 2] = -x[3 * b0 - 2];  // the separator's multipliers, negated here
  y[3 * n - 1] = -x[3 * b0 - 1];
  auto finish = [&](int c) {
    const int k = n_bodies - 1 - c;  // its rows: 3k (knife edge), 3k+1, 3k+2 (the hitch c-1 -> c)
    const bool later = c + 1 < n_bodies;  // the hitch c -> c+1: rows 3k-2, 3k-1
    const double values[5] = {-y[3 * k + 1], -y[3 * k + 2], y[3 * k], later ? -y[3 * k - 2] : 0.0,
                              later ? -y[3 * k - 1] : 0.0};
    correct_body_with(body, c, so, values, h, ph, qn);
    sin_cos(qn[3 * c + 2], sc + 2 * c);
    y[3 * k] = 0.0;
    if (c == b0) return;  // the separator's gap: the calling thread's
    double gx, gy;
    hitch_gap_xy(body[c - 1], qn + 3 * c - 3, sc + 2 * c - 2, gx, gy);
    track_worst(gx, gy, worst);
    y[3 * k + 1] = -(scale * gx);
    y[3 * k + 2] = -(scale * gy);
  };
  auto no_border = [](double*, int) {};
  for (int k = n - 1; k >= 0; --k) {
    back_substitute_body(*cp.tail, k, n_bodies, k == n - 1, y, no_border);
    const int b = n_bodies - 1 - k;
    if (b > b0) finish(b - 1);
  }
  finish(n_bodies - 1);
}

}  // namespace nonholo::detail
