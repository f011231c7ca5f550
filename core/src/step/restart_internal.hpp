#pragma once
// The pieces of restart.hpp that the step calls on its candidate state (workspace buffers)
// before committing it. Preconditions for all three: the workspace holds mu(q) in mu_values
// and the factorisation of C(q); `applied` is f(t, q) when the model has an applied force
// (ignored otherwise). They use ws.velocity, p_half, p_hat, scratch_n, scratch_n2, rhs,
// scratch_m, lambda_s, lambda_f and the map_* buffers as scratch.
#include <nonholo/model.hpp>
#include <nonholo/restart_options.hpp>
#include <nonholo/state.hpp>
#include <nonholo/status.hpp>
#include <nonholo/workspace.hpp>

#include <algorithm>
#include <cmath>
#include <limits>

namespace nonholo::detail {

// Plans the packed storage of the momentum maps' directions (Workspace::map_slot): each map's
// support (a local symmetry's body, widened to whole blocks of M; else all of p), grown as the
// Gram-Schmidt of momentum_directions can grow it (by the earlier supports it overlaps, in
// order), and for each map the earlier ones it overlaps. Returns the pool's size. O(r log r +
// overlaps) for r maps: a chain of N balls plans its N + 2 in O(N log N).
int plan_map_slots(const Model& model, std::vector<int>& slot, std::vector<int>& overlap_ptr,
                   std::vector<int>& overlap);

// parasitic_amplitude (restart.hpp) without taking the workspace: for a step that holds it.
Status parasitic_amplitude(const Model& model, Workspace& ws, const State& s, double h, double& amplitude,
                           double min_pivot_ratio);

// ws.lambda_s = lambda_s(q, M^-1 p), the continuous multiplier; leaves ws.velocity = M^-1 p.
Status continuous_multiplier_at(const Model& model, Workspace& ws, ConstVecRef q, ConstVecRef p,
                                ConstVecRef applied);

// In holonomic mode the first half kick of the step from q_k adds (h/2) G to p_half, G =
// mu_k^T dlambda_k (the gap corrections), and the constraint kick at q_{k+1} projects it: in
// momenta, the arriving kick (h/2) mu^T lambda~_{k+1} = -P (p~_k + the departing kick), P =
// mu^T C^-1 mu M^-1 at q_{k+1}, so lambda~ settles at lambda_s - x with x = C^-1 mu M^-1 G/2,
// and the period-2 mode is the alternating part about that. (The offset was dlambda/2 until
// issue 23: the same where mu_k ~ mu_{k+1}, but where C is nearly singular, a chain passing a
// configuration where its one-forms become dependent, dlambda is large along C(q_k)'s
// near-null direction and mu_{k+1}^T dlambda is not small: it read as a mode of 1.2 where
// there was 0.02, and the restart that set lambda~ = lambda_s - dlambda/2 failed.)
// gap_offset: the step made gap corrections; x is in ws.offset_multiplier.

// G/2 = (p_half - p~_k - (h/2) force_k) / h into out (n entries), with ws.p_half the step's
// corrected first half kick and `from` the state it started from.
void gap_momentum_half(const Workspace& ws, const State& from, double h, VecRef out);
// ws.offset_multiplier = x = C^-1 mu M^-1 G/2 at q = ws.q_next (C(q) factorised, p_half as
// left by the step); uses ws.scratch_n, scratch_n2 and rhs.
Status gap_offset_multiplier(const Model& model, Workspace& ws, const State& from, double h);

// The amplitude from its squared norms: mode = |mu^T (lambda - lambda_s (+ x))|^2, arriving =
// |p_-|^2 with p_- = p - (h/2)(mu^T lambda + f) the arriving post-momentum, kicks = |mu^T
// lambda|^2 + |f|^2 (all in M^-1):
//   (h/2) sqrt(mode) / sqrt(arriving + (h/2)^2 kicks).
// p_-, not p~: the mode takes its energy from p~ while p_- keeps it (the post-momentum energy is
// exact), so a mode that drained p~ to 8% (a sleigh at v0 = 1e4, h = 0.01) reads about 1 of
// the momentum, where |p~| read 21.9. The kicks are the floor for a body at rest (p~ = p_- = 0
// to round-off, held by balanced forces: a disk standing under gravity): then the amplitude is
// the mode's share of the kicks, at round-off eps cond, not round-off over round-off (it read 3).
inline double parasitic_amplitude_of(double mode, double arriving, double kicks, double h) {
  const double scale = arriving + 0.25 * h * h * kicks;
  if (!(scale > 0.0)) return mode > 0.0 ? std::numeric_limits<double>::infinity() : 0.0;
  return 0.5 * h * std::sqrt(mode / scale);
}

// The amplitude above right after continuous_multiplier_at(q, p) (and with gap_offset,
// gap_offset_multiplier); f is ws.applied. Also uses ws.p_hat.
double parasitic_of(const Model& model, Workspace& ws, ConstVecRef p, ConstVecRef lambda, double h,
                    bool gap_offset);

// After continuous_multiplier_at(q, p) (and with gap_offset, gap_offset_multiplier): lambda <-
// lambda_s(q, p') (- x with gap_offset), with p' the rescale of p that keeps the arriving
// post-momentum energy (plus the averaged potential), and force <- f + mu^T lambda. On failure
// p, lambda and force are unchanged.
Status rescaled_restart(const Model& model, Workspace& ws, ConstVecRef q, VecRef p, VecRef lambda,
                        VecRef force, ConstVecRef applied, double h, bool gap_offset);

// The composed step's energy projection: p <- p_J + s p_r (p_J: what the momentum maps see,
// kept; p_r: the rest) with s > 0 such that (1/2) p^T M^-1 p + V(q) = target. Needs mu(q)
// and C(q) in the workspace only with momentum maps. On failure (no such s) p is unchanged.
Status project_energy(const Model& model, Workspace& ws, ConstVecRef q, VecRef p, double target);

// --- the measurement schedule, shared by the explicit and the implicit step ----------------
// Whether the step that arrives at step count `now` measures the amplitude, or restarts
// periodically.
inline bool measurement_due(const RestartOptions& o, const ModeWatch& w, long now) {
  return o.monitor_every > 0 && now >= w.next_step;
}
inline bool periodic_restart_due(const RestartOptions& o, long now) {
  return o.mode == RestartMode::Periodic && o.every > 0 && now % o.every == 0;
}
// After measuring amplitude a at step `now`: plans the next measurement and returns whether
// Auto restarts. Without Auto the measurement only reports, every monitor_every steps. With
// it the amplitude is predicted from its growth per step g between the last two measurements
// (g = 2 when unknown: where the motion attracts strongly, a whipped trailer, the mode doubles
// per step); the next measurement comes after the most steps, up to monitor_every, that keep
// the prediction below half the tolerance, and at the next step once the tolerance is passed.
bool plan_after_measurement(const RestartOptions& o, double h, ModeWatch& w, long now, double a);
// After a restart at step `now`: the mode starts again from its seed; Auto measures it next step.
void plan_after_restart(const RestartOptions& o, ModeWatch& w, long now);

// The scale s closest to 1 with g(s) = 0, for g increasing near 1 with g(1) = g1 and slope
// about `slope` there; |g| <= floor counts as 0: a bracket grown from 1 by the Newton
// estimate, then Illinois regula falsi. Returns false when no bracket exists (no positive
// scale keeps the energy).
template <class G>
bool find_scale(G&& g, double g1, double slope, double floor, double& s_out) {
  constexpr double eps = std::numeric_limits<double>::epsilon();
  s_out = 1.0;
  if (std::abs(g1) <= floor) return true;
  double d = (slope > 0.0 && std::isfinite(slope)) ? std::abs(g1) / slope : 1e-8;
  d = std::max(d, 16.0 * eps);
  double lo, hi, glo, ghi;
  if (g1 > 0.0) {
    hi = 1.0;
    ghi = g1;
    for (int i = 0;; ++i, d *= 4.0) {
      lo = std::max(0.0, 1.0 - 2.0 * d);
      glo = g(lo);
      if (glo <= 0.0) break;
      if (lo == 0.0 || i == 60 || !std::isfinite(glo)) return false;
      hi = lo;
      ghi = glo;
    }
  } else {
    lo = 1.0;
    glo = g1;
    for (int i = 0;; ++i, d *= 4.0) {
      hi = 1.0 + 2.0 * d;
      ghi = g(hi);
      if (ghi >= 0.0) break;
      if (i == 60 || !std::isfinite(ghi)) return false;
      lo = hi;
      glo = ghi;
    }
  }
  double best = std::abs(glo) < std::abs(ghi) ? lo : hi, best_g = std::min(std::abs(glo), std::abs(ghi));
  int side = 0;
  for (int it = 0; it < 200 && best_g > floor && hi - lo > 4.0 * eps * hi; ++it) {
    double s = (lo * ghi - hi * glo) / (ghi - glo);
    if (!(s > lo && s < hi)) s = 0.5 * (lo + hi);
    const double gs = g(s);
    if (std::abs(gs) < best_g) {
      best = s;
      best_g = std::abs(gs);
    }
    if (gs < 0.0) {
      lo = s;
      glo = gs;
      if (side == -1) ghi *= 0.5;
      side = -1;
    } else {
      hi = s;
      ghi = gs;
      if (side == 1) glo *= 0.5;
      side = 1;
    }
  }
  s_out = best;
  return true;
}

// The energy an arriving post-momentum p_- carries at q: (1/2) p_-^T M^-1 p_-, plus with a
// potential (V(q_{k-1}) + V(q)) / 2, the averaged potential diagnose() reports.
// minv(x, y) sets y = M^-1 x; w: n entries of scratch; previous(p_-, v_-) returns V(q_{k-1})
// given p_- and v_- = M^-1 p_- (and may overwrite v_-): V(q - h v_-) on flat models
// (flat_previous_potential).
template <class Minv, class Previous>
double arriving_energy(const Model& model, ConstVecRef q, ConstVecRef p_minus, Minv&& minv, VecRef w,
                       Previous&& previous) {
  minv(p_minus, w);
  double e = 0.5 * p_minus.dot(w);
  if (model.has_potential()) e += 0.5 * (previous(p_minus, w) + model.potential(q));
  return e;
}

// previous() of arriving_energy for a model without rigid bodies: V(q - h v_-), in v_-'s buffer.
inline auto flat_previous_potential(const Model& model, ConstVecRef q, double h) {
  return [&model, q, h](ConstVecRef, VecRef v_minus) {
    v_minus = q - h * v_minus;
    return model.potential(v_minus);
  };
}

// The message of a restart whose arithmetic overflowed (its plain energy change not finite), for
// ws.fail with the target energy and the change: the state is too fast or too forced for the step,
// whose quadratic terms (h times the bias, which grows as the speed squared) leave the doubles'
// range. (It advised "restart less often".) A literal: a failing step allocates nothing either.
#define NONHOLO_OVERFLOWING_RESTART                                                                           \
  "the restart's arithmetic overflowed (post-momentum energy %.3g, energy change of the plain restart %.3g): "  \
  "the state is too fast or too forced for this step size (the step's quadratic terms, h times the constraint " \
  "forces that grow as the speed squared, leave the range of doubles); reduce the step size by orders of "     \
  "magnitude, or choose units that bring the speeds and forces nearer 1"

// The scale s next to 1 that gives the arriving post-momentum p_-(s) = a + s b + s^2 c the
// energy `target` (arriving_energy): (1/2)|p_-(s)|^2_{M^-1} is a quartic in s, the potential
// is evaluated at each trial (through previous(), as arriving_energy). False when no positive scale does it; `plain` is then the
// energy change at s = 1. w1, w2: n entries of scratch each (a, b, c must not be them).
template <class Minv, class Previous>
bool scale_keeping_energy(const Model& model, ConstVecRef q, ConstVecRef a, ConstVecRef b, ConstVecRef c,
                          double target, Minv&& minv, VecRef w1, VecRef w2, Previous&& previous, double& s,
                          double& plain) {
  minv(a, w1);
  const double aa = a.dot(w1), ab = b.dot(w1), ac = c.dot(w1);
  minv(c, w1);
  const double bc = b.dot(w1), cc = c.dot(w1);
  minv(b, w1);
  const double bb = b.dot(w1);
  const double k0 = 0.5 * aa, k1 = ab, k2 = 0.5 * bb + ac, k3 = bc, k4 = 0.5 * cc;
  const bool potential = model.has_potential();
  const double v_now = potential ? model.potential(q) : 0.0;
  auto residual = [&](double x) {
    double e = (((k4 * x + k3) * x + k2) * x + k1) * x + k0;
    if (potential) {
      w1 = a + x * b + (x * x) * c;
      minv(w1, w2);
      e += 0.5 * (previous(w1, w2) + v_now);
    }
    return e - target;
  };
  plain = residual(1.0);
  const double floor = 8.0 * std::numeric_limits<double>::epsilon() *
                       (std::abs(target) + std::abs(k0) + std::abs(k1) + std::abs(k2) + std::abs(k3) + std::abs(k4) +
                        std::abs(v_now));
  return std::isfinite(plain) && find_scale(residual, plain, k1 + 2.0 * k2 + 3.0 * k3 + 4.0 * k4, floor, s);
}

}  // namespace nonholo::detail
