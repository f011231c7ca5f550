// The explicit step of a chain of elements in two sweeps over the bodies (docs/design.md section 7):
//
// forward, body i entering: half kick and drift of body i, sin/cos of its new angle, its
//   thrust and the spring to body i-1 at t_{k+1}; then body i-1 is complete: p^ = p_half +
//   (h/2) f and v^ = M^-1 p^; the rows of group i-1 (knife edge of i-1, hitch i-1 -> i) get
//   their values, their band rows of C = mu M^-1 mu^T and are eliminated (LDL^T); the rows of
//   group i-2, whose v^ are now all known, get their right-hand side -(2/h) mu v^ and are
//   forward-substituted;
// backward, group g leaving: back substitution of its rows gives lambda~_{k+1}; body g+1 (one
//   body behind) then has all its multipliers: p~ = p^ + (h/2) mu^T lambda~, force = f +
//   mu^T lambda~, and the residual of its rows and the energies are summed.
// Every body's data is touched once per sweep; no pass over C, mu or the state besides.
// The result is the step of rattle.cpp's detail::advance (the same arithmetic in another
// order: they agree to round-off, tests/test_chain_sweep.cpp).
#include <nonholo/rattle.hpp>

#include <algorithm>
#include <cmath>

#include "model/element_set.hpp"
#include "step/chain/chain_partitions.hpp"
#include "step/chain/chain_rows.hpp"
#include "step/chain/chain_sweep.hpp"
#include "step/chain/sweep_common.hpp"

namespace nonholo::detail {
namespace {
// KD: the band's half-bandwidth when known at compile time (the loops unroll), else -1.
template <int KD>
Status sweep(const Model& model, Workspace& ws, const State& st, const RattleOptions& o, double h, double t_next,
             bool kicked, double& check) {
  const ElementSet& set = *model.element_set();
  const ChainBodies body = set.chain_bodies();
  const int n_bodies = body.size();
  const int m = model.num_one_forms();
  sparse::BandedLdlt& band = *ws.banded();
  const int kd = KD >= 0 ? KD : band.bandwidth();
  const double half = 0.5 * h, rhs_scale = -2.0 / h;
  const bool forced = model.has_applied_force();

  start_sweep(ws);
  Forward fw(model, ws, st, h, t_next, kicked);
  double *qn = fw.qn, *pn = fw.pn, *fa = fw.fa, *fn = fw.fn, *lam = fw.lam, *mu = fw.mu, *sc = fw.sc;
  Group groups[2];        // groups b and b-1, by parity of b
  double vhat[2][3] = {};  // M^-1 p^ of bodies b and b-1, by parity
  double gap = 0.0;
  int row_of_group[2] = {0, 0};  // first row of the groups in `groups`
  int next_row = 0, next_value = 0, rhs_row = 0;

  for (int i = 0; i <= n_bodies + 1; ++i) {
    if (i < n_bodies) fw.enter(i, true);  // body i enters
    if (i >= 1 && i <= n_bodies) {  // body b = i-1 is complete: p^, v^, and its group's rows
      const int b = i - 1;
      const ChainBody& cb = body[b];
      const double w[3] = {cb.wx, cb.wy, cb.wt};
      double* v = vhat[b & 1];
      fw.complete(b, cb, v);
      Group& g = groups[b & 1];
      const Group& prev = groups[(b + 1) & 1];
      const double* sc_next = b + 1 < n_bodies ? sc + 2 * b + 2 : sc + 2 * b;
      next_value += group_rows(cb, sc + 2 * b, sc_next, g, mu + next_value);
      if (cb.flags & kChainHitch) {  // the hitch's gap at q_{k+1}
        const double* a = qn + 3 * b;
        const double* f = qn + 3 * b + 3;
        gap = std::max(gap, std::abs(a[0] - cb.d * sc[2 * b + 1] - f[0] - cb.f * sc_next[1]));
        gap = std::max(gap, std::abs(a[1] - cb.d * sc[2 * b] - f[1] - cb.f * sc_next[0]));
      }
      const int first = next_row, prev_first = row_of_group[(b + 1) & 1];
      row_of_group[b & 1] = first;
      const double* wn = b + 1 < n_bodies ? &body[b + 1].wx : w;  // wx, wy, wt are consecutive
      for (int j = 0; j < g.rows; ++j) {
        group_band_row(g, j, first, b > 0 ? &prev : nullptr, prev_first, w, wn, kd, band.row(first + j));
        if (!band.template eliminate_row<KD>(first + j, o.min_pivot_ratio))
          return pivot_failure(ws, band, o.min_pivot_ratio);
      }
      next_row += g.rows;
    }
    if (i >= 2) {  // group g = i-2: right-hand side and forward substitution
      const int gi = i - 2;
      const Group& g = groups[gi & 1];
      const double* v0 = vhat[gi & 1];
      const double* v1 = vhat[(gi + 1) & 1];  // unused (v = 0) when the group has no hitch
      for (int j = 0; j < g.rows; ++j) {
        lam[rhs_row] = rhs_scale * (dot3(g.u[j], v0) + dot3(g.v[j], v1));
        band.template forward_row<KD>(rhs_row, lam);
        ++rhs_row;
      }
    }
  }

  // Backward: lambda~ group by group; body g+1 is finished once group g is known.
  BlockSum kinetic;
  double residual = 0.0;
  Group later;                // group g+1, whose rows were solved in the previous iteration
  double vlater[3] = {0, 0, 0};  // M^-1 p~ of body g+2
  int row = m;
  auto finish_body = [&](int b, const Group* own, int own_first, const Group* before, int before_first) {
    // mu^T lambda on body b: its own group's u rows and the previous group's v rows.
    double g3[3] = {0.0, 0.0, 0.0};
    for (int j = 0; j < own->rows; ++j)
      for (int c = 0; c < 3; ++c) g3[c] += own->u[j][c] * lam[own_first + j];
    if (before)
      for (int j = 0; j < before->rows; ++j)
        for (int c = 0; c < 3; ++c) g3[c] += before->v[j][c] * lam[before_first + j];
    const ChainBody& cb = body[b];
    const double w[3] = {cb.wx, cb.wy, cb.wt};
    double v[3], kin = 0.0, chk = 0.0;
    for (int c = 0; c < 3; ++c) {
      const double pc = pn[3 * b + c] + half * g3[c];
      pn[3 * b + c] = pc;
      fn[3 * b + c] = forced ? fa[3 * b + c] + g3[c] : g3[c];
      v[c] = w[c] * pc;
      kin += pc * v[c];
      chk += pc + fn[3 * b + c];
    }
    kinetic.add(kin);
    check += chk;
    // Residual of body b's rows: mu M^-1 p~ over bodies b and b+1.
    for (int j = 0; j < own->rows; ++j)
      residual = std::max(residual, std::abs(dot3(own->u[j], v) + dot3(own->v[j], vlater)));
    vlater[0] = v[0], vlater[1] = v[1], vlater[2] = v[2];
  };
  int later_first = m;
  for (int b = n_bodies - 1; b >= 0; --b) {
    Group g;
    const double* sc_next = b + 1 < n_bodies ? sc + 2 * b + 2 : sc + 2 * b;
    group_rows(body[b], sc + 2 * b, sc_next, g, nullptr);
    const int first = row - g.rows;
    for (int r = row - 1; r >= first; --r) band.template backward_row<KD>(r, lam);
    if (b + 1 < n_bodies) finish_body(b + 1, &later, later_first, &g, first);
    later = g;
    later_first = first;
    row = first;
  }
  finish_body(0, &later, later_first, nullptr, 0);

  return fw.finish(ws, band, o.min_pivot_ratio, kinetic, residual, gap, true, check);
}


// The common chain (ElementSet::hitched_chain): the same sweeps with the rows of body b in
// closed form. Body b has rows k = 3b (knife edge [s, -c, a]), x = 3b+1 and y = 3b+2 (the
// hitch to b+1, [1, 0, d s | -1, 0, f s'] and [0, 1, -d c | 0, -1, -f c']), so with
// w = diag(M^-1) and fp the previous hitch's f, C's band rows are closed forms in s, c, s', c'.
Status sweep_hitched(const Model& model, Workspace& ws, const State& st, const RattleOptions& o, double h,
                     double t_next, bool kicked, double& check) {
  constexpr int KD = 4;
  const ElementSet& set = *model.element_set();
  const ChainBodies body = set.chain_bodies();
  const int n_bodies = body.size();
  sparse::BandedLdlt& band = *ws.banded();
  const double half = 0.5 * h, rhs_scale = -2.0 / h;
  const bool forced = model.has_applied_force();

  start_sweep(ws);
  Forward fw(model, ws, st, h, t_next, kicked);
  double *qn = fw.qn, *pn = fw.pn, *fa = fw.fa, *fn = fw.fn, *lam = fw.lam, *sc = fw.sc;
  double vhat[2][3] = {};
  double gap = 0.0;

  for (int i = 0; i <= n_bodies + 1; ++i) {
    if (i < n_bodies) fw.enter(i, !kicked);  // body i enters
    if (i >= 1 && i <= n_bodies) {  // body b = i-1 complete: p^, v^, its rows of C eliminated
      const int b = i - 1;
      const ChainBody& cb = body[b];
      const double wx = cb.wx, wy = cb.wy, wt = cb.wt;
      double* v = vhat[b & 1];
      fw.complete(b, cb, v);
      const double s = sc[2 * b], c = sc[2 * b + 1], a = cb.a;
      const double fp = b > 0 ? body[b - 1].f : 0.0;  // the previous hitch's front distance
      const int r = 3 * b;
      double* row = band.row(r);
      row[0] = row[1] = 0.0;
      row[2] = -wx * s + wt * a * fp * s;
      row[3] = wy * c - wt * a * fp * c;
      row[4] = wx * s * s + wy * c * c + wt * a * a;
      const bool interior = b >= 2;  // rows r - 4 .. r exist: the band's zeros are skipped
      if (!(interior ? band.eliminate_interior_row<KD, 2>(r, o.min_pivot_ratio)
                     : band.eliminate_row<KD>(r, o.min_pivot_ratio))) return pivot_failure(ws, band, o.min_pivot_ratio);
      if (b + 1 < n_bodies) {
        const ChainBody& nb = body[b + 1];
        const double sn = sc[2 * b + 2], cn = sc[2 * b + 3], d = cb.d, f = cb.f;
        const double wtd = wt * d, wtnf = nb.wt * f;
        double* rx = band.row(r + 1);
        rx[0] = 0.0;
        rx[1] = -wx + wtd * fp * s * s;
        rx[2] = -wtd * fp * s * c;
        rx[3] = wx * s + wtd * a * s;
        rx[4] = wx + wtd * d * s * s + nb.wx + wtnf * f * sn * sn;
        double* ry = band.row(r + 2);
        ry[0] = -wtd * fp * s * c;
        ry[1] = -wy + wtd * fp * c * c;
        ry[2] = -wy * c - wtd * a * c;
        ry[3] = -wtd * d * s * c - wtnf * f * sn * cn;
        ry[4] = wy + wtd * d * c * c + nb.wy + wtnf * f * cn * cn;
        gap = std::max(gap, std::abs(qn[3 * b] - d * c - qn[3 * b + 3] - f * cn));
        gap = std::max(gap, std::abs(qn[3 * b + 1] - d * s - qn[3 * b + 4] - f * sn));
        const bool ok = interior ? band.eliminate_interior_row<KD, 1>(r + 1, o.min_pivot_ratio) &&
                                       band.eliminate_interior_row<KD, 0>(r + 2, o.min_pivot_ratio)
                                 : band.eliminate_row<KD>(r + 1, o.min_pivot_ratio) &&
                                       band.eliminate_row<KD>(r + 2, o.min_pivot_ratio);
        if (!ok) return pivot_failure(ws, band, o.min_pivot_ratio);
      }
    }
    if (i >= 2) {  // group g = i-2: right-hand side -(2/h) mu v^ and forward substitution
      const int g = i - 2;
      const ChainBody& cb = body[g];
      const double* v = vhat[g & 1];
      const double s = sc[2 * g], c = sc[2 * g + 1];
      const int r = 3 * g;
      const bool interior = g >= 2;
      lam[r] = rhs_scale * (s * v[0] - c * v[1] + cb.a * v[2]);
      interior ? band.forward_interior_row<KD, 2>(r, lam) : band.forward_row<KD>(r, lam);
      if (g + 1 < n_bodies) {
        const double* vn = vhat[(g + 1) & 1];
        const double sn = sc[2 * g + 2], cn = sc[2 * g + 3];
        lam[r + 1] = rhs_scale * (v[0] + cb.d * s * v[2] - vn[0] + cb.f * sn * vn[2]);
        interior ? band.forward_interior_row<KD, 1>(r + 1, lam) : band.forward_row<KD>(r + 1, lam);
        lam[r + 2] = rhs_scale * (v[1] - cb.d * c * v[2] - vn[1] - cb.f * cn * vn[2]);
        interior ? band.forward_interior_row<KD, 0>(r + 2, lam) : band.forward_row<KD>(r + 2, lam);
      }
    }
  }

  // Backward: the rows of body b solved, then body b+1 finished (its rows and the hitch b -> b+1).
  BlockSum kinetic;
  double residual = 0.0;
  double vlater[3] = {0.0, 0.0, 0.0};  // M^-1 p~ of the body after the one being finished
  const double* forces = forced ? fa : nullptr;
  auto finish_body = [&](int b) {
    double v[3];
    residual = std::max(residual, finish_hitched_body(body, b, sc, lam, half, forces, pn, fn, kinetic, check, v));
    const ChainBody& cb = body[b];
    const double s = sc[2 * b], c = sc[2 * b + 1];
    if (b + 1 < n_bodies) {
      const double sn = sc[2 * b + 2], cn = sc[2 * b + 3];
      residual = std::max(residual, std::abs(v[0] + cb.d * s * v[2] - vlater[0] + cb.f * sn * vlater[2]));
      residual = std::max(residual, std::abs(v[1] - cb.d * c * v[2] - vlater[1] - cb.f * cn * vlater[2]));
    }
    vlater[0] = v[0], vlater[1] = v[1], vlater[2] = v[2];
  };
  for (int b = n_bodies - 1; b >= 0; --b) {
    const int r = 3 * b;
    if (b + 3 < n_bodies) {  // rows up to r + 7 exist: the band's zeros are skipped
      band.backward_interior_row<KD, 3>(r + 2, lam);
      band.backward_interior_row<KD, 4>(r + 1, lam);
      band.backward_interior_row<KD, 2>(r, lam);
    } else {
      if (b + 1 < n_bodies) {
        band.backward_row<KD>(r + 2, lam);
        band.backward_row<KD>(r + 1, lam);
      }
      band.backward_row<KD>(r, lam);
    }
    if (b + 1 < n_bodies) finish_body(b + 1);
  }
  finish_body(0);

  // mu is not written: the next step's holonomic corrections take their rows from these sin/cos
  // (Workspace::chain_sincos_prev), a restart or diagnose() fills mu from them when it asks.
  return fw.finish(ws, band, o.min_pivot_ratio, kinetic, residual, gap, false, check);
}


// Knife edges only (ElementSet::knife_chain): C is diagonal, C_bb = wx s^2 + wy c^2 + wt a^2,
// so each body's multiplier follows as soon as its p^ is known (one body behind, for the
// spring to the next body): the whole step is one forward sweep. `forced`: the model has an
// applied force (fixed at compile time: on a single sleigh its branches cost a tenth of the step).
template <bool forced>
Status sweep_knives(const Model& model, Workspace& ws, const State& st, const RattleOptions& o, double h,
                    double t_next, double& check) {
  const ElementSet& set = *model.element_set();
  const ChainBodies body = set.chain_bodies();
  const int n_bodies = body.size();
  sparse::BandedLdlt& band = *ws.banded();
  const double half = 0.5 * h, rhs_scale = -2.0 / h;

  start_sweep(ws);
  Forward fw(model, ws, st, h, t_next, false);
  double *pn = fw.pn, *fa = fw.fa, *fn = fw.fn, *lam = fw.lam, *sc = fw.sc;
  BlockSum kinetic;
  double residual = 0.0;
  for (int i = 0; i <= n_bodies; ++i) {
    if (i < n_bodies) fw.enter<0, forced>(i, true);  // body i enters
    if (i >= 1) {  // body b = i-1 complete: its multiplier and p~ at once
      const int b = i - 1;
      const ChainBody& cb = body[b];
      const double s = sc[2 * b], c = sc[2 * b + 1], a = cb.a;
      double* pb = pn + 3 * b;
      if (forced)
        for (int k = 0; k < 3; ++k) pb[k] += half * fa[3 * b + k];
      const double m3[3] = {s, -c, a};
      band.row(b)[0] = cb.wx * s * s + cb.wy * c * c + cb.wt * a * a;
      if (!band.eliminate_row<0>(b, o.min_pivot_ratio)) return pivot_failure(ws, band, o.min_pivot_ratio);
      const double l = rhs_scale * (s * cb.wx * pb[0] - c * cb.wy * pb[1] + a * cb.wt * pb[2]) * band.row(b)[0];
      lam[b] = l;
      double v[3], kin = 0.0, chk = 0.0;
      for (int k = 0; k < 3; ++k) {
        const double g = l * m3[k];
        const double pc = pb[k] + half * g;
        pb[k] = pc;
        fn[3 * b + k] = forced ? fa[3 * b + k] + g : g;
        v[k] = (&cb.wx)[k] * pc;
        kin += pc * v[k];
        chk += pc + fn[3 * b + k];
      }
      kinetic.add(kin);
      check += chk;
      residual = std::max(residual, std::abs(s * v[0] - c * v[1] + a * v[2]));
    }
  }
  return fw.finish(ws, band, o.min_pivot_ratio, kinetic, residual, 0.0, false, check);
}

}  // namespace

Status chain_sweep(const Model& model, Workspace& ws, const State& st, const RattleOptions& o, double h,
                   double t_next, bool kicked, double& check) {
  if (knife_sweep(model, ws, kicked))
    return model.has_applied_force() ? sweep_knives<true>(model, ws, st, o, h, t_next, check)
                                     : sweep_knives<false>(model, ws, st, o, h, t_next, check);
  if (model.element_set()->hitched_chain) {  // kd = 4
    if (ws.partitions()) return sweep_hitched_parted(model, ws, st, o, h, t_next, kicked, check);
    return sweep_hitched(model, ws, st, o, h, t_next, kicked, check);
  }
  switch (ws.banded()->bandwidth()) {  // chains: 4 (knife edges and hitches), 0 (knife edges only)
    case 0: return sweep<0>(model, ws, st, o, h, t_next, kicked, check);
    case 3: return sweep<3>(model, ws, st, o, h, t_next, kicked, check);
    case 4: return sweep<4>(model, ws, st, o, h, t_next, kicked, check);
    default: return sweep<-1>(model, ws, st, o, h, t_next, kicked, check);
  }
}

}  // namespace nonholo::detail
