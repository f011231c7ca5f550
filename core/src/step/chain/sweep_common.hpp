#pragma once
// What the fused chain sweeps share (chain_sweep.cpp on one thread, chain_partitions.cpp on
// several): the blocked sums, the pivot failure's report, and Forward, the work on each body as
// it enters the forward sweep.
#include <nonholo/rattle.hpp>

#include <algorithm>
#include <cmath>

#include "model/element_set.hpp"
#include "step/chain/chain_rows.hpp"

namespace nonholo::detail {

// A sum over a million bodies in blocks of 64: its round-off grows like (64 + N/64) eps
// rather than N eps (the energies of a 10^5-body chain: 7e-12 relative in one running sum).
struct BlockSum {
  double total = 0.0, part = 0.0;
  int count = 0;
  void add(double x) {
    part += x;
    if (++count == 64) {
      total += part;
      part = 0.0;
      count = 0;
    }
  }
  double value() const { return total + part; }
};

// A row failed its pivot test: the status and message factorize() would give.
inline Status pivot_failure(Workspace& ws, sparse::BandedLdlt& band, double min_pivot_ratio) {
  ++ws.factorizations;
  return ws.report_factor_failure(band.finish_rows(min_pivot_ratio));
}

// Body b of the common chain (ElementSet::hitched_chain) once its multipliers are known (its
// knife edge's, its hitch's to b+1, the hitch's from b-1): p~ = p^ + (h/2) mu^T lambda~ in pn,
// the force f + mu^T lambda~ in fn, v = M^-1 p~, its kinetic energy and finiteness sums; returns
// its knife edge's residual. (The hitches' residuals need the next body's v: the caller's.)
inline double finish_hitched_body(const ChainBodies& body, int b, const double* sc, const double* lam, double half,
                                  const double* fa, double* pn, double* fn, BlockSum& kinetic, double& check,
                                  double* v) {
  const int n_bodies = body.size();
  const ChainBody& cb = body[b];
  const double s = sc[2 * b], c = sc[2 * b + 1];
  const int r = 3 * b;
  const double lk = lam[r];
  const double lx = b + 1 < n_bodies ? lam[r + 1] : 0.0, ly = b + 1 < n_bodies ? lam[r + 2] : 0.0;
  const double px = b > 0 ? lam[r - 2] : 0.0, py = b > 0 ? lam[r - 1] : 0.0;  // hitch b-1 -> b
  const double fp = b > 0 ? body[b - 1].f : 0.0;
  const double g3[3] = {s * lk + lx - px, -c * lk + ly - py,
                        cb.a * lk + cb.d * (s * lx - c * ly) + fp * (s * px - c * py)};
  double kin = 0.0, chk = 0.0;
  for (int k = 0; k < 3; ++k) {
    const double pc = pn[3 * b + k] + half * g3[k];
    pn[3 * b + k] = pc;
    fn[3 * b + k] = fa ? fa[3 * b + k] + g3[k] : g3[k];
    v[k] = (&cb.wx)[k] * pc;
    kin += pc * v[k];
    chk += pc + fn[3 * b + k];
  }
  kinetic.add(kin);
  check += chk;
  return std::abs(s * v[0] - c * v[1] + cb.a * v[2]);
}

// Every sweep starts so: the cached one-forms are about to be overwritten, and the band is
// refilled row by row.
inline void start_sweep(Workspace& ws) {
  ws.forget_one_forms();
  ws.banded()->begin_rows();
}

// What every sweep does as body i enters the forward sweep: the half kick and drift (unless
// holonomic mode did them, `kicked`), the cache key, the sums for energy_post and the
// finiteness check, sin/cos of the new angle (unless the holonomic gap pass left them), and with
// forces, body i's thrusts and the springs between bodies i-1 and i at t_{k+1} (then body
// i-1's applied force is complete).
// On a partition [lo, hi) of the bodies (chain_partitions.cpp) a spring across its ends is
// computed by both sides from the drifted angle of the other side's body (the same arithmetic
// as that body's own drift, so the same bits; `kicked`: holonomic mode's passes drifted every
// body before), each writing only its own body's torque; the potential is counted by the
// partition on the right.
struct Forward {
  const ElementSet& set;
  const ChainBodies body;
  const double *q, *p, *force;
  double *qn, *ph, *fa, *key, *sc;
  double *pn, *fn, *lam, *mu;  // p^ then p~_{k+1}; force_{k+1}; rhs, y, then lambda~; mu values
  double h, t_next;
  bool kicked, forced;
  int lo = 0, hi;  // the bodies this sweep enters
  // The thrusts' force and torque at t_next (2 per thrust), evaluated before the partitions'
  // threads start (a callback is not known to be safe to call from several threads); null: the
  // sweep calls them.
  const double* thrust_values = nullptr;
  std::size_t next_thrust = 0, thrust_end;  // the thrusts on [lo, hi): [next_thrust, thrust_end)
  BlockSum kinetic_post;
  double potential_old = 0.0, potential_new = 0.0, check = 0.0;

  Forward(const Model& model, Workspace& ws, const State& st, double step, double t, bool was_kicked)
      : set(*model.element_set()), body(set.chain_bodies()), q(st.q.data()), p(st.p.data()),
        force(st.force.data()), qn(ws.q_next.data()), ph(was_kicked ? ws.p_half.data() : ws.p_next.data()),
        fa(ws.applied.data()), key(ws.one_form_key()), sc(ws.chain_sincos.data()), pn(ws.p_next.data()),
        fn(ws.force_next.data()), lam(ws.lambda.data()), mu(ws.mu_values.data()), h(step), t_next(t),
        kicked(was_kicked), forced(model.has_applied_force()), hi(body.size()), thrust_end(set.thrusts.size()) {}

  // Only the bodies [first, last) enter (a partition's).
  void restrict_to(int first, int last) {
    lo = first;
    hi = last;
    const auto& thrusts = set.thrusts;
    auto bound = [&](int b) {
      return static_cast<std::size_t>(
          std::lower_bound(thrusts.begin(), thrusts.end(), b, [](const Thrust& t, int c) { return t.body < c; }) -
          thrusts.begin());
    };
    next_thrust = bound(first);
    thrust_end = bound(last);
  }

  // Body b is complete (its forces at t_{k+1} are in): p^ = p_half + (h/2) f into pn, and
  // v^ = M^-1 p^ into v.
  void complete(int b, const ChainBody& cb, double* v) const {
    const double half = 0.5 * h;
    for (int c = 0; c < 3; ++c) {
      const double pc = forced ? ph[3 * b + c] + half * fa[3 * b + c] : ph[3 * b + c];
      pn[3 * b + c] = pc;
      v[c] = (&cb.wx)[c] * pc;
    }
  }

  // The sweeps' common end: the pivot summary, the caches (mu written or left to
  // evaluate_one_forms), the diagnostics of the new state, the finiteness sum.
  Status finish(Workspace& ws, sparse::BandedLdlt& band, double min_pivot_ratio, const BlockSum& kinetic,
                double residual, double gap, bool mu_written, double& total_check) const {
    band.finish_rows(min_pivot_ratio);
    total_check += check;
    ws.one_forms_factorized_at_key(mu_written);
    auto& d = ws.step_diagnostics;
    d.energy = 0.5 * kinetic.value() + potential_new;
    d.energy_post = 0.5 * kinetic_post.value() + 0.5 * (potential_old + potential_new);
    d.residual = residual;
    d.gap = gap;
    return Status::Ok;
  }

  // The angle body b drifts to (enter's arithmetic, not kicked).
  double drifted_angle(int b) const {
    const double pb = p[3 * b + 2] + 0.5 * h * force[3 * b + 2];
    return q[3 * b + 2] + h * body[b].wt * pb;
  }

  // Kicked, Forced: 1 or 0 fixes `kicked` or `forced` at compile time (a small model's sweep
  // is mostly these branches), -1 reads the member.
  template <int Kicked = -1, int Forced = -1>
  void enter(int i, bool trigonometry) {
    const bool was_kicked = Kicked >= 0 ? Kicked == 1 : kicked;
    double* qi = move(i, was_kicked, trigonometry);
    if (!(Forced >= 0 ? Forced == 1 : forced)) return;
    double* f = fa + 3 * i;
    f[0] = f[1] = f[2] = 0.0;
    for (; next_thrust < thrust_end && set.thrusts[next_thrust].body == i; ++next_thrust) push(next_thrust, f, i);
    if (i > 0 && body[i - 1].k != 0.0) {  // springs between i-1 and i, D = theta_{i-1} - theta_i
      // Another partition's body, not drifted yet unless holonomic mode's passes drifted all.
      const double before = i == lo && !was_kicked ? drifted_angle(i - 1) : qn[3 * i - 1];
      const double torque = spring(i - 1, before, qi[2]);
      if (i != lo) fa[3 * i - 1] -= torque;
      f[2] += torque;
    }
    const ChainBody& b = body[i];
    if (i + 1 == hi && hi < body.size() && b.k != 0.0)  // the spring to the next partition's first body
      f[2] -= b.k * (qi[2] - (was_kicked ? qn[3 * (i + 1) + 2] : drifted_angle(i + 1))) - b.kr;
  }

  // The same with the bodies entering from the last (hi - 1) down to lo: a partition swept
  // from the chain's tail (chain_partitions_tail.cpp), the last partition (hi = the chain's end).
  // Body i's applied force is complete once body i-1 has entered (the spring between them).
  void enter_reversed(int i, bool trigonometry) {
    double* qi = move(i, kicked, trigonometry);
    if (!forced) return;
    double* f = fa + 3 * i;
    f[0] = f[1] = f[2] = 0.0;
    std::size_t k = thrust_end;  // body i's thrusts, in their order
    while (k > next_thrust && set.thrusts[k - 1].body == i) --k;
    for (std::size_t t = k; t < thrust_end; ++t) push(t, f, i);
    thrust_end = k;
    if (i + 1 < hi && body[i].k != 0.0) {  // the spring to i+1, which entered before
      const double torque = spring(i, qi[2], qn[3 * i + 5]);
      f[2] -= torque;
      fa[3 * i + 5] += torque;
    }
    if (i == lo && i > 0 && body[i - 1].k != 0.0)  // the spring from the partition before
      f[2] += spring(i - 1, kicked ? qn[3 * i - 1] : drifted_angle(i - 1), qi[2]);
  }

 private:
  // Half kick and drift of body i (unless `was_kicked`), its key and sums, sin/cos.
  double* move(int i, bool was_kicked, bool trigonometry) {
    const ChainBody& b = body[i];
    const double w[3] = {b.wx, b.wy, b.wt};
    double* qi = qn + 3 * i;
    double* pi = ph + 3 * i;
    double kin = 0.0, chk = 0.0;  // one add per body to each long sum (they are serial)
    for (int c = 0; c < 3; ++c) {
      if (!was_kicked) {
        pi[c] = p[3 * i + c] + 0.5 * h * force[3 * i + c];
        qi[c] = q[3 * i + c] + h * w[c] * pi[c];
      }
      key[3 * i + c] = qi[c];
      kin += w[c] * pi[c] * pi[c];
      chk += qi[c];
    }
    kinetic_post.add(kin);
    check += chk;
    if (trigonometry) sin_cos(qi[2], sc + 2 * i);
    return qi;
  }
  // Thrust t on body i at t_{k+1}.
  void push(std::size_t t, double* f, int i) {
    const Thrust& th = set.thrusts[t];
    if (th.force) {
      const double push = thrust_values ? thrust_values[2 * t] : th.force(t_next);
      f[0] += push * sc[2 * i + 1];
      f[1] += push * sc[2 * i];
    }
    if (th.torque) f[2] += thrust_values ? thrust_values[2 * t + 1] : th.torque(t_next);
  }
  // The spring between bodies b and b+1 at angles (before, after): its torque dV/dD, its
  // potential at t_{k+1} and at t_k (counted by the partition of body b+1).
  double spring(int b, double before, double after) {
    const ChainBody& sb = body[b];
    const double now = before - after, old = q[3 * b + 2] - q[3 * b + 5];
    potential_new += 0.5 * (sb.k * now * now + sb.krr) - sb.kr * now;
    potential_old += 0.5 * (sb.k * old * old + sb.krr) - sb.kr * old;
    return sb.k * now - sb.kr;
  }

 public:
};

}  // namespace nonholo::detail
