// The common chain's one-form step on several threads (chain_partitions.hpp): each thread's
// forward sweep over its partition (the one-thread sweep's work, plus the border), the
// separators' 2x2 block-tridiagonal system on one thread, each thread's back substitution and
// its bodies' p~ and force; and the solve with the factorisation this leaves.
#include "base/thread_team.hpp"
#include "step/chain/chain_partitions.hpp"


#include <atomic>
#include <cmath>

#include "step/chain/chain_sweep.hpp"
#include "step/chain/hitched_band_rows.hpp"

namespace nonholo::detail {

namespace {

constexpr int KD = kChainBandwidth;

// A partition with a border (every one but the first and the last) costs about 1.5 times a
// plain one per body (measured in the lab prototype, ../shared/lab/chain_threads: 1.55 on a 2-core AMD EPYC).
constexpr double kPlainWeight = 1.5;

}  // namespace

ChainPartitions::ChainPartitions(int bodies, int count, int thrusts, sparse::BandedLdlt* band, double* shared_tail_x)
    : parts(count) {
  // Plain partitions (the first; the last, from the tail) take kPlainWeight times a bordered
  // one's bodies.
  std::vector<double> weight(parts, 1.0);
  weight.front() = weight.back() = kPlainWeight;
  double total = 0.0, acc = 0.0;
  for (double w : weight) total += w;
  first.assign(parts + 1, 0);
  for (int j = 1; j < parts; ++j) {
    acc += weight[j - 1];
    first[j] = static_cast<int>(std::lround(bodies * acc / total));
  }
  first[parts] = bodies;
  for (int j = 1; j < parts; ++j)  // at least 2 bodies each (bodies >= 2 parts)
    first[j] = std::max(first[j], first[j - 1] + 2);
  for (int j = parts - 1; j >= 1; --j) first[j] = std::min(first[j], first[j + 1] - 2);
  // Only the bordered partitions' rows, all before the tail's, have border entries.
  tail_first = parts > 1 ? first[parts - 1] : bodies;
  border.assign(parts > 2 ? 2 * static_cast<std::size_t>(3 * tail_first) : 0, 0.0);
  if (parts > 1) {
    const int n = bodies - tail_first;
    // Its rows: the band's from 3 tail_first (those of its left separator, two before, are the
    // head partition's) to 3 bodies = the band's size + 2 (a hitched chain has 3 bodies - 2 rows).
    const bool inside = band && band->bandwidth() == kChainBandwidth &&
                        band->size() + band->spare_rows() >= 3 * bodies && 3 * tail_first <= band->size();
    tail = inside ? std::make_unique<sparse::BandedLdlt>(3 * n, kChainBandwidth, band->row(3 * tail_first))
                  : std::make_unique<sparse::BandedLdlt>(3 * n, kChainBandwidth);
    if (!shared_tail_x) tail_storage.assign(3 * static_cast<std::size_t>(n), 0.0);
    tail_x = shared_tail_x ? shared_tail_x : tail_storage.data();
  }
  part.assign(parts, Part{});
  thrust_values.assign(2 * static_cast<std::size_t>(thrusts), 0.0);
  block.assign(std::max(parts - 1, 0), Block{});
}

namespace {

// One partition's share of the step. First: partition 0, without a border (fixed at compile
// time: the border's dead code in the plain partition's loop cost it about 30 % in the lab).
template <bool First>
struct PartSweep {
  static constexpr bool first = First;
  const Model& model;
  Workspace& ws;
  ChainPartitions& cp;
  sparse::BandedLdlt& band;
  const ChainBodies body;
  const int n_bodies, j, b0, b1;
  const bool last;  // no right separator
  const double h, min_pivot_ratio;
  double* lb;
  ChainPartitions::Part& out;

  PartSweep(const Model& m, Workspace& w, int index, double step, double ratio)
      : model(m), ws(w), cp(*w.partitions()), band(*w.banded()), body(m.element_set()->chain_bodies()),
        n_bodies(body.size()), j(index), b0(cp.first[index]), b1(cp.first[index + 1]),
        last(index + 1 == cp.parts), h(step), min_pivot_ratio(ratio), lb(cp.border.data()), out(cp.part[index]) {}

  // Row r's border entries (the left separator's x and y rows against r) once r is eliminated:
  // C(s, r) (cx, cy) less the earlier border entries times L(r, c) D(c) (work[t], c = r - 4 + t).
  template <int LO>
  void border(int r, double cx, double cy, const double (&work)[KD]) {
    double wx = cx, wy = cy;
    for (int t = LO; t < KD; ++t) {
      const double* l = lb + 2 * static_cast<std::ptrdiff_t>(r - KD + t);
      wx -= l[0] * work[t];
      wy -= l[1] * work[t];
    }
    const double inverse = band.row(r)[KD];
    const double lx = wx * inverse, ly = wy * inverse;
    lb[2 * static_cast<std::ptrdiff_t>(r)] = lx;
    lb[2 * static_cast<std::ptrdiff_t>(r) + 1] = ly;
    out.left_schur[0] += wx * lx, out.left_schur[1] += wx * ly, out.left_schur[2] += wy * ly;
  }
  // Row r eliminated with its columns before LO zero (a partition's first rows: LO counts the
  // left separator's columns too), and its border when there is one.
  template <int LO>
  bool eliminate(int r, double cx = 0.0, double cy = 0.0) {
    double work[KD];
    if (!band.eliminate_interior_row<KD, LO>(r, min_pivot_ratio, out.pivots, work)) return false;
    if (!first) border<LO>(r, cx, cy, work);
    return true;
  }
  // The same for the chain's first rows (partition 0: the band's own bounds).
  bool eliminate_head(int r) { return band.eliminate_row<KD>(r, min_pivot_ratio, out.pivots); }

  // The right separator's rows (hitch b -> b+1, b = b1 - 1) against this partition's last
  // three rows r-2, r-1, r (r = 3b): their L in the separator's band rows, their Schur block in
  // right_schur, and with the left border the block between the two separators in cross.
  void separator_rows(int r, double* rx, double* ry) {
    double wx[3], wy[3];
    detail::separator_rows(band, r, rx, ry, out.right_schur, wx, wy);
    double X[2][2] = {{0.0, 0.0}, {0.0, 0.0}};
    if (!first)
      for (int t = 0; t < 3; ++t) {
        const double* l = lb + 2 * static_cast<std::ptrdiff_t>(r - 2 + t);
        X[0][0] += l[0] * wx[t], X[0][1] += l[0] * wy[t], X[1][0] += l[1] * wx[t], X[1][1] += l[1] * wy[t];
      }
    for (int a = 0; a < 2; ++a)
      for (int e = 0; e < 2; ++e) out.cross[a][e] = X[a][e];
  }

  // The forward sweep over [b0, b1): sweep_hitched's, with the left separator's columns moved
  // to the border and the right separator's rows reduced to their Schur block.
  bool forward(const State& st, double t_next, bool kicked) {
    Forward fw(model, ws, st, h, t_next, kicked);
    fw.restrict_to(b0, b1);
    fw.thrust_values = cp.thrust_values.data();
    double *qn = fw.qn, *lam = fw.lam, *sc = fw.sc;
    const double rhs_scale = -2.0 / h;
    double vhat[2][3] = {};
    double gap = 0.0, border_y[2] = {0.0, 0.0};
    const PartRows rows(band, cp, j, n_bodies);
    for (int i = b0; i <= b1 + 1; ++i) {
      if (i < b1) fw.enter(i, !kicked);  // body i enters (holonomic passes left its sin/cos)
      if (i > b0 && i <= b1) {  // body b = i-1 complete: p^, v^, its rows eliminated
        const int b = i - 1;
        const ChainBody& cb = body[b];
        double* v = vhat[b & 1];
        fw.complete(b, cb, v);
        const double s = sc[2 * b], c = sc[2 * b + 1];
        const double fp = b > 0 ? body[b - 1].f : 0.0;
        const int r = 3 * b;
        const bool start = b == b0;  // its rows meet the left separator's
        double* rk = band.row(r);
        knife_band_row(cb, s, c, fp, rk);
        bool ok;
        if (first) {
          ok = b >= 2 ? eliminate<2>(r) : eliminate_head(r);
        } else if (start) {
          const double cx = rk[2], cy = rk[3];
          rk[2] = rk[3] = 0.0;
          ok = eliminate<KD>(r, cx, cy);
        } else {
          ok = eliminate<2>(r);
        }
        if (!ok) return false;
        if (b + 1 < n_bodies) {
          double* rx = band.row(r + 1);
          double* ry = band.row(r + 2);
          if (b == b1 - 1 && !last) {
            hitch_band_rows(cb, nullptr, s, c, 0.0, 0.0, fp, rx, ry);
            separator_rows(r, rx, ry);
          } else {
            hitch_band_rows(cb, &body[b + 1], s, c, sc[2 * b + 2], sc[2 * b + 3], fp, rx, ry);
            hitch_gap(cb, qn + 3 * b, sc + 2 * b, gap);
            if (first) {
              ok = b >= 2 ? eliminate<1>(r + 1) && eliminate<0>(r + 2)
                          : eliminate_head(r + 1) && eliminate_head(r + 2);
            } else if (start) {
              const double cx1 = rx[1], cy1 = rx[2], cx2 = ry[0], cy2 = ry[1];
              rx[1] = rx[2] = ry[0] = ry[1] = 0.0;
              ok = eliminate<3>(r + 1, cx1, cy1) && eliminate<2>(r + 2, cx2, cy2);
            } else {
              ok = eliminate<1>(r + 1) && eliminate<0>(r + 2);
            }
            if (!ok) return false;
          }
        }
      }
      if (i >= b0 + 2) {  // group g = i-2: right-hand side and forward substitution
        const int g = i - 2;
        const ChainBody& cb = body[g];
        const double* v = vhat[g & 1];
        const double s = sc[2 * g], c = sc[2 * g + 1];
        const int r = 3 * g;
        lam[r] = rhs_scale * (s * v[0] - c * v[1] + cb.a * v[2]);
        if (rows.hitch_rows(g)) hitch_rhs(cb, sc + 2 * g, v, vhat[(g + 1) & 1], rhs_scale, lam + r + 1);
        rows.template forward<First>(g, lam, border_y, out.right_y);
      }
    }
    out.left_y[0] = border_y[0], out.left_y[1] = border_y[1];
    out.kinetic_post = fw.kinetic_post;
    out.potential_old = fw.potential_old, out.potential_new = fw.potential_new;
    out.check = fw.check;
    out.gap = gap;
    return true;
  }

  // Back substitution over [b0, b1) (the separators' multipliers known), each body finished:
  // p~ = p^ + (h/2) mu^T lambda~, force, its energy and its rows' residuals.
  void backward() {
    const double half = 0.5 * h;
    const bool forced = model.has_applied_force();
    const double* sc = ws.chain_sincos.data();
    const double* fa = ws.applied.data();
    double *pn = ws.p_next.data(), *fn = ws.force_next.data(), *lam = ws.lambda.data();
    BlockSum kinetic;
    double residual = 0.0, check = 0.0, vlater[3] = {0.0, 0.0, 0.0};
    const double* forces = forced ? fa : nullptr;
    auto finish_body = [&](int b) {
      double v[3];
      residual = std::max(residual, finish_hitched_body(body, b, sc, lam, half, forces, pn, fn, kinetic, check, v));
      const ChainBody& cb = body[b];
      if (b + 1 < b1) hitch_residual(cb, sc + 2 * b, v, vlater, residual);  // a separator's: after the join
      vlater[0] = v[0], vlater[1] = v[1], vlater[2] = v[2];
    };
    const Unborder border_term(cp, j, lam);
    auto unborder = [&](double* x, int r) {
      if (!first) border_term(x, r);  // compiled out of partition 0's loop
    };
    for (int b = b1 - 1; b >= b0; --b) {
      back_substitute_body(band, b, n_bodies, b == b1 - 1 && !last, lam, unborder);
      if (b + 1 < b1) finish_body(b + 1);
    }
    finish_body(b0);
    out.kinetic = kinetic;
    out.residual = residual;
    out.check += check;
  }
};

// The separators' system on one thread: block j is C's 2x2 block of s_j less the Schur
// complements of the partitions on both sides, coupled to s_{j+1} through partition j+1's
// cross block; block LDL^T, each 2x2 pivot tested as the band's rows are (rows 3b+1, 3b+2).
// The multipliers go to lambda (`rhs`: from the sweeps' partial sums; the solve's own).
bool factor_separators(const Model& model, Workspace& ws, double min_pivot_ratio, sparse::PivotLog& log) {
  ChainPartitions& cp = *ws.partitions();
  const ChainBodies body = model.element_set()->chain_bodies();
  const double* sc = ws.chain_sincos.data();
  for (int j = 0; j + 1 < cp.parts; ++j) {
    const int b = cp.first[j + 1] - 1;
    const ChainBody& cb = body[b];
    const double fp = b > 0 ? body[b - 1].f : 0.0;
    double rx[5], ry[5];
    hitch_band_rows(cb, &body[b + 1], sc[2 * b], sc[2 * b + 1], sc[2 * b + 2], sc[2 * b + 3], fp, rx, ry);
    const ChainPartitions::Part &left = cp.part[j], &right = cp.part[j + 1];
    double D[3] = {rx[4] - left.right_schur[0] - right.left_schur[0], ry[3] - left.right_schur[1] - right.left_schur[1],
                   ry[4] - left.right_schur[2] - right.left_schur[2]};
    ChainPartitions::Block& k = cp.block[j];
    for (int a = 0; a < 2; ++a)
      for (int e = 0; e < 2; ++e) k.up[a][e] = -right.cross[a][e];
    if (j > 0) {  // D -= U_{j-1}^T D'_{j-1}^-1 U_{j-1}
      const ChainPartitions::Block& pk = cp.block[j - 1];
      const double* iv = pk.inverse;
      double M[2][2];  // D'^-1 U
      for (int e = 0; e < 2; ++e) {
        M[0][e] = iv[0] * pk.up[0][e] + iv[1] * pk.up[1][e];
        M[1][e] = iv[1] * pk.up[0][e] + iv[2] * pk.up[1][e];
      }
      D[0] -= pk.up[0][0] * M[0][0] + pk.up[1][0] * M[1][0];
      D[1] -= pk.up[0][0] * M[0][1] + pk.up[1][0] * M[1][1];
      D[2] -= pk.up[0][1] * M[0][1] + pk.up[1][1] * M[1][1];
    }
    // D = [1 0; l 1] diag(d0, d1) [1 l; 0 1]
    double inv0 = 0.0, inv1 = 0.0;
    if (!log.accept(3 * b + 1, &inv0, D[0], rx[4], min_pivot_ratio)) return false;
    const double l = D[1] * inv0;
    if (!log.accept(3 * b + 2, &inv1, D[2] - l * D[1], ry[4], min_pivot_ratio)) return false;
    k.inverse[0] = inv0 + l * l * inv1;
    k.inverse[1] = -l * inv1;
    k.inverse[2] = inv1;
  }
  return true;
}

// The step's separators: their right-hand sides from the velocities of both sides, the
// system factorised and solved; their gaps.
bool reduce(const Model& model, Workspace& ws, double h, double min_pivot_ratio, sparse::PivotLog& log,
            double& gap) {
  ChainPartitions& cp = *ws.partitions();
  if (!factor_separators(model, ws, min_pivot_ratio, log)) return false;
  const ChainBodies body = model.element_set()->chain_bodies();
  const double *sc = ws.chain_sincos.data(), *pn = ws.p_next.data(), *qn = ws.q_next.data();
  for (int j = 0; j + 1 < cp.parts; ++j) {
    const int b = cp.first[j + 1] - 1;
    const ChainBody &cb = body[b], &nb = body[b + 1];
    double v[3], vn[3], rhs[2];
    for (int k = 0; k < 3; ++k) v[k] = (&cb.wx)[k] * pn[3 * b + k], vn[k] = (&nb.wx)[k] * pn[3 * b + 3 + k];
    hitch_rhs(cb, sc + 2 * b, v, vn, -2.0 / h, rhs);
    hitch_gap(cb, qn + 3 * b, sc + 2 * b, gap);
    for (int a = 0; a < 2; ++a) cp.block[j].rhs[a] = rhs[a] - cp.part[j].right_y[a] - cp.part[j + 1].left_y[a];
  }
  solve_separators(cp, ws.lambda.data());
  return true;
}

}  // namespace

void solve_separators(ChainPartitions& cp, double* x) {
  const int count = cp.parts - 1;
  for (int j = 1; j < count; ++j) {  // r'_j = r_j - U_{j-1}^T D'_{j-1}^-1 r'_{j-1}
    const ChainPartitions::Block& pk = cp.block[j - 1];
    const double* iv = pk.inverse;
    const double z0 = iv[0] * pk.rhs[0] + iv[1] * pk.rhs[1], z1 = iv[1] * pk.rhs[0] + iv[2] * pk.rhs[1];
    cp.block[j].rhs[0] -= pk.up[0][0] * z0 + pk.up[1][0] * z1;
    cp.block[j].rhs[1] -= pk.up[0][1] * z0 + pk.up[1][1] * z1;
  }
  double next[2] = {0.0, 0.0};
  for (int j = count - 1; j >= 0; --j) {
    const ChainPartitions::Block& k = cp.block[j];
    double t0 = k.rhs[0], t1 = k.rhs[1];
    if (j + 1 < count) {
      t0 -= k.up[0][0] * next[0] + k.up[0][1] * next[1];
      t1 -= k.up[1][0] * next[0] + k.up[1][1] * next[1];
    }
    next[0] = k.inverse[0] * t0 + k.inverse[1] * t1;
    next[1] = k.inverse[1] * t0 + k.inverse[2] * t1;
    const int r = 3 * (cp.first[j + 1] - 1) + 1;
    x[r] = next[0], x[r + 1] = next[1];
  }
}

Status sweep_hitched_parted(const Model& model, Workspace& ws, const State& st, const RattleOptions& o, double h,
                            double t_next, bool kicked, double& check) {
  ChainPartitions& cp = *ws.partitions();
  sparse::BandedLdlt& band = *ws.banded();
  start_sweep(ws);
  for (auto& part : cp.part) part = ChainPartitions::Part{};
  // The thrusts on this thread (their callbacks may throw: the caller's guard catches it here).
  const auto& thrusts = model.element_set()->thrusts;
  for (std::size_t k = 0; k < thrusts.size(); ++k) {
    cp.thrust_values[2 * k] = thrusts[k].force ? thrusts[k].force(t_next) : 0.0;
    cp.thrust_values[2 * k + 1] = thrusts[k].torque ? thrusts[k].torque(t_next) : 0.0;
  }
  const int parts = cp.parts;
  sparse::PivotLog separators;
  double separator_gap = 0.0;
  std::atomic<bool> forward_ok{true};
  bool reduced_ok = true;
  // Nothing in the job throws (the thrusts were called above), so nothing escapes it.
  auto job = [&](TeamMember& member) {
    // MXCSR is per thread and the pool's workers do not inherit it: flush subnormals in each.
    const FlushSubnormals flush;
    const int team = member.size();  // fewer than the partitions: in turn
    bool ok = true;
    for (int j = member.index(); j < parts; j += team)
      ok = (j == 0            ? PartSweep<true>(model, ws, j, h, o.min_pivot_ratio).forward(st, t_next, kicked)
            : is_tail(cp, j) ? tail_sweep_forward(model, ws, st, h, t_next, kicked, o.min_pivot_ratio)
                              : PartSweep<false>(model, ws, j, h, o.min_pivot_ratio).forward(st, t_next, kicked)) &&
           ok;
    if (!ok) forward_ok.store(false, std::memory_order_relaxed);
    member.barrier();
    if (member.index() == 0 && forward_ok.load(std::memory_order_relaxed))
      reduced_ok = reduce(model, ws, h, o.min_pivot_ratio, separators, separator_gap);
    member.barrier();
    if (forward_ok.load(std::memory_order_relaxed) && reduced_ok)
      for (int j = member.index(); j < parts; j += team) {
        if (j == 0)
          PartSweep<true>(model, ws, j, h, o.min_pivot_ratio).backward();
        else if (is_tail(cp, j))
          tail_sweep_backward(model, ws, h);
        else
          PartSweep<false>(model, ws, j, h, o.min_pivot_ratio).backward();
      }
  };
  ThreadPool::run(ws.team(), job);
  // The partitions' pivot tests in row order, then the separators'.
  for (const auto& part : cp.part) band.merge_pivots(part.pivots);
  band.merge_pivots(separators);
  if (!forward_ok || !reduced_ok) return pivot_failure(ws, band, o.min_pivot_ratio);
  band.finish_rows(o.min_pivot_ratio);

  // The sums in partition order (bitwise the same for the same partitions); the separators'
  // hitch residuals, whose bodies two partitions finished.
  const ChainBodies body = model.element_set()->chain_bodies();
  const double *sc = ws.chain_sincos.data(), *pn = ws.p_next.data();
  double kinetic = 0.0, kinetic_post = 0.0, potential_old = 0.0, potential_new = 0.0, residual = 0.0;
  double gap = separator_gap;
  for (const auto& part : cp.part) {
    kinetic += part.kinetic.value();
    kinetic_post += part.kinetic_post.value();
    potential_old += part.potential_old;
    potential_new += part.potential_new;
    residual = std::max(residual, part.residual);
    gap = std::max(gap, part.gap);
    check += part.check;
  }
  for (int j = 0; j + 1 < parts; ++j) {
    const int b = cp.first[j + 1] - 1;
    const ChainBody &cb = body[b], &nb = body[b + 1];
    double v[3], vn[3];
    for (int k = 0; k < 3; ++k) v[k] = (&cb.wx)[k] * pn[3 * b + k], vn[k] = (&nb.wx)[k] * pn[3 * b + 3 + k];
    hitch_residual(cb, sc + 2 * b, v, vn, residual);
  }
  ws.one_forms_factorized_at_key(false, true);
  auto& d = ws.step_diagnostics;
  d.energy = 0.5 * kinetic + potential_new;
  d.energy_post = 0.5 * kinetic_post + 0.5 * (potential_old + potential_new);
  d.residual = residual;
  d.gap = gap;
  return Status::Ok;
}

void solve_parted(const Model& model, Workspace& ws, const double* b, double* x) {
  ChainPartitions& cp = *ws.partitions();
  sparse::BandedLdlt& band = *ws.banded();
  const int n_bodies = model.num_bodies(), m = model.num_one_forms(), parts = cp.parts;
  if (x != b)
    for (int r = 0; r < m; ++r) x[r] = b[r];
  // Each partition's forward substitution (as the sweep orders its rows) and its partial sums
  // for the separators; the separators on one thread; each partition's back substitution.
  auto job = [&](TeamMember& member) {
    const FlushSubnormals flush;
    const int team = member.size();
    for (int j = member.index(); j < parts; j += team) forward_partition(band, cp, j, n_bodies, x);
    member.barrier();
    if (member.index() == 0) {
      for (int j = 0; j + 1 < parts; ++j) {
        const int r = 3 * (cp.first[j + 1] - 1) + 1;
        for (int a = 0; a < 2; ++a) cp.block[j].rhs[a] = x[r + a] - cp.part[j].right_y[a] - cp.part[j + 1].left_y[a];
      }
      solve_separators(cp, x);
    }
    member.barrier();
    for (int j = member.index(); j < parts; j += team) backward_partition(band, cp, j, n_bodies, x);
  };
  ThreadPool::run(ws.team(), job);
}

}  // namespace nonholo::detail
