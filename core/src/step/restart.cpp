// Energy-exact restarts of the multipliers (docs/design.md section 8). The arriving post-momentum
// of a state is p_- = p~ - (h/2)(f + mu^T lambda~). A restart replaces lambda~ by the
// continuous multiplier of a rescaled momentum p~' = p~_J + s p~_r (p~_J: what the momentum
// maps see, kept; p~_r: the rest, scaled). Since the bias is quadratic in the velocity,
// lambda_s(q, p~_J + s p~_r) = lambda_F + lambda_0 + s lambda_1 + s^2 lambda_2, and p_-(s) =
// a + s b + s^2 c with fixed vectors a, b, c: its energy is a quartic in s, and with a
// potential the averaged V of docs/design.md is added. One scalar equation keeps the energy.
// Where the maps see all of p~, p~ stays and lambda~ = lambda_F + s^2 lambda_B (b = 0).
#include <nonholo/restart.hpp>

#include <nonholo/diagnostics.hpp>
#include <nonholo/dynamics.hpp>

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <queue>
#include <vector>

#include "base/callback_guard.hpp"
#include "step/dynamics_internal.hpp"
#include "step/restart_internal.hpp"
#include "step/rigid/drift.hpp"

namespace nonholo {
namespace detail {
namespace {

constexpr double kEps = std::numeric_limits<double>::epsilon();

// x^T M^-1 y for the model's block-diagonal M. scratch: n entries.
double inverse_mass_dot(const Model& model, ConstVecRef x, ConstVecRef y, VecRef scratch) {
  model.inverse_mass().multiply(x.data(), scratch.data());
  return y.dot(scratch);
}

// lambda = -C^-1 rhs_in (rhs_in is negated in place).
Status solve_negated(Workspace& ws, Vector& rhs, double* lambda) {
  rhs = -rhs;
  return ws.solve(rhs.data(), lambda);
}

// Direction j's entry k (Workspace::map_slot: k within its slot).
inline double& slot_entry(Workspace& ws, int j, int k) {
  const int* slot = ws.map_slot.data() + 3 * j;
  return ws.map_pool[slot[0] + k - slot[1]];
}

// The velocities a map's direction starts on: a local symmetry's body, widened to whole blocks
// of M, else all of them.
void support_of(const Model& model, const NamedMomentumMap& map, int& lo, int& hi) {
  const auto& mass = model.mass();
  lo = 0;
  hi = model.num_velocities();
  if (map.body < 0 || hi == 0) return;
  const Body& body = model.body(map.body);
  if (body.size == 0) return;
  lo = mass.block_offset(mass.block_of(body.offset));
  const int last = mass.block_of(body.offset + body.size - 1);
  hi = mass.block_offset(last) + mass.block_size(last);
}

// The momentum maps' directions xi_j = dJ_j/dp at q, in D(q) and M-orthonormalised into
// ws.map_pool (a direction orthogonal to D, or dependent on the others, becomes 0): a
// declared symmetry's generator lies in D already (checked at the start); a probed map's
// direction is projected M-orthogonally onto D(q). For p with M^-1 p in D, J_j(q, p) = xi_j^T p =
// (P xi_j)^T p. Also records J_j(q, p) and the scale sum_i |xi_ji p_i| in ws.map_values, and
// where each direction is nonzero in ws.map_span (whole blocks of M): the modified Gram-Schmidt
// meets only the earlier directions whose slots overlap (Workspace::map_overlap) and skips
// those whose spans do not, so N local generators (one ball's spin each) cost O(N), not
// O(N^2) full-length products. Each direction is built in ws.map_linear (zero outside the
// direction's span between directions) and then stored packed.
Status momentum_directions(const Model& model, Workspace& ws, ConstVecRef q, ConstVecRef p) {
  // mu(q) is cached (the step that arrived at q left it, or its sin/cos for a fused step).
  if (const Status status = ws.evaluate_one_forms(q); status != Status::Ok) return status;
  const auto& maps = model.momentum_maps();
  const auto& mass = model.mass();
  const int n = model.num_velocities(), r = static_cast<int>(maps.size());
  int* span = ws.map_span.data();
  double* col = ws.map_linear.data();  // the direction being built, at its own indices
  ws.map_probe.setZero();
  ws.map_linear.setZero();
  ws.map_pool.setZero();
  // x^T M y on the entries [lo, hi) (block aligned); ws.scratch_n is clobbered there.
  const double* diagonal = mass.is_diagonal() ? mass.diagonal() : nullptr;
  auto m_dot = [&](const double* x, const double* y, int lo, int hi) {
    if (diagonal) {  // the same products and sums, without the call and the scratch stream
      double s = 0.0;
      for (int i = lo; i < hi; ++i) s += (diagonal[i] * x[i]) * y[i];
      return s;
    }
    mass.multiply(x, ws.scratch_n.data(), lo, hi);
    double s = 0.0;
    for (int i = lo; i < hi; ++i) s += ws.scratch_n[i] * y[i];
    return s;
  };
  for (int j = 0; j < r; ++j) {
    int& lo = span[2 * j];
    int& hi = span[2 * j + 1];
    double scale = 0.0;
    if (maps[j].generator) {  // a declared symmetry: xi itself, J = <xi, p>
      int first = 0, last = n;
      support_of(model, maps[j], first, last);
      maps[j].generator(q, ws.map_linear);  // a local one writes its body's entries only
      double value = 0.0;
      for (int i = first; i < last; ++i) {
        scale += std::abs(col[i] * p[i]);
        value += col[i] * p[i];
      }
      ws.map_values[j] = maps[j].body < 0 ? ws.map_linear.dot(p) : value;  // over all of p as before: the same bits
      lo = first;  // its nonzero entries, widened to whole blocks of M
      hi = last;
      while (lo < hi && col[lo] == 0.0) ++lo;
      while (hi > lo && col[hi - 1] == 0.0) --hi;
      if (lo < hi) {
        lo = mass.block_offset(mass.block_of(lo));
        hi = mass.block_offset(mass.block_of(hi - 1)) + mass.block_size(mass.block_of(hi - 1));
      } else {
        lo = hi = 0;
      }
    } else {  // probed: J(q, e_i) - J(q, 0)
      const double offset = maps[j].map(q, ws.map_probe);
      for (int i = 0; i < n; ++i) {
        ws.map_probe[i] = 1.0;
        col[i] = maps[j].map(q, ws.map_probe) - offset;
        ws.map_probe[i] = 0.0;
        scale += std::abs(col[i] * p[i]);
      }
      ws.map_values[j] = maps[j].map(q, p);
      lo = 0;
      hi = n;
    }
    ws.map_values[r + j] = scale + std::abs(ws.map_values[j]);
    if (!std::isfinite(scale) || !std::isfinite(ws.map_values[j]))
      return ws.fail(Status::RestartFailed, "momentum map '%s' is not finite at this state", maps[j].name.c_str());
    const double before = std::sqrt(std::max(0.0, m_dot(col, col, lo, hi)));  // its M-norm as given
    if (!maps[j].generator) {  // onto D(q): minus M^-1 mu^T C^-1 mu col
      Status status = Status::Ok;
      model.mu_times(ws.mu_values.data(), col, ws.rhs.data());
      if ((status = ws.solve(ws.rhs.data(), ws.scratch_m.data())) != Status::Ok) return status;
      model.mu_transpose_times(ws.mu_values.data(), ws.scratch_m.data(), ws.scratch_n.data());
      model.inverse_mass().multiply(ws.scratch_n.data(), ws.scratch_n2.data());
      ws.map_linear -= ws.scratch_n2;
    }
    // Modified Gram-Schmidt in the M inner product, where they overlap: d = xi_i^T M col.
    for (int at = ws.map_overlap_ptr[j]; at < ws.map_overlap_ptr[j + 1]; ++at) {
      const int i = ws.map_overlap[at];
      const int a = std::max(lo, span[2 * i]), b = std::min(hi, span[2 * i + 1]);
      if (a >= b) continue;
      for (int k = a; k < b; ++k) ws.scratch_n2[k] = slot_entry(ws, i, k);
      const double d = m_dot(ws.scratch_n2.data(), col, a, b);
      if (d == 0.0) continue;
      for (int k = span[2 * i]; k < span[2 * i + 1]; ++k) col[k] -= d * slot_entry(ws, i, k);
      lo = std::min(lo, span[2 * i]);
      hi = std::max(hi, span[2 * i + 1]);
    }
    const double norm = std::sqrt(std::max(0.0, m_dot(col, col, lo, hi)));
    // Where col may be nonzero: its support (a local generator's body) and its span.
    int touched_lo = 0, touched_hi = n;
    if (maps[j].generator && maps[j].body >= 0) {
      support_of(model, maps[j], touched_lo, touched_hi);
      if (lo < hi) {
        touched_lo = std::min(touched_lo, lo);
        touched_hi = std::max(touched_hi, hi);
      }
    }
    if (norm > 1e-10 * before) {
      for (int k = lo; k < hi; ++k) slot_entry(ws, j, k) = col[k] / norm;
    } else {
      lo = hi = 0;
    }
    for (int k = touched_lo; k < touched_hi; ++k) col[k] = 0.0;  // zero again for the next
  }
  return Status::Ok;
}

// p = p_J + p_r with p_J = M v_J what the momentum maps see: v_J = sum_j xi_j (xi_j^T p) over
// the M-orthonormal directions of momentum_directions; leaves v_J in ws.scratch_n and p_r in
// ws.map_rest. p_J and p_r are M^-1-orthogonal, and J_j(q, p_J + s p_r) = J_j(q, p) for all s.
Status split_by_maps(const Model& model, Workspace& ws, ConstVecRef q, ConstVecRef p) {
  const Status status = momentum_directions(model, ws, q, p);
  if (status != Status::Ok) return status;
  const int r = static_cast<int>(model.momentum_maps().size());
  ws.scratch_n.setZero();
  for (int j = 0; j < r; ++j) {
    const int lo = ws.map_span[2 * j], hi = ws.map_span[2 * j + 1];
    double d = 0.0;
    for (int k = lo; k < hi; ++k) d += slot_entry(ws, j, k) * p[k];
    for (int k = lo; k < hi; ++k) ws.scratch_n[k] += d * slot_entry(ws, j, k);
  }
  model.mass().multiply(ws.scratch_n.data(), ws.map_rest.data());
  ws.map_rest = p - ws.map_rest;
  return Status::Ok;
}

// Checks that the new momentum leaves every map at the value split_by_maps recorded.
Status maps_unchanged(const Model& model, Workspace& ws, ConstVecRef q, ConstVecRef p_new) {
  const auto& list = model.momentum_maps();
  const int r = static_cast<int>(list.size());
  ws.map_probe.setZero();
  for (int j = 0; j < r; ++j) {
    double after = 0.0;
    if (list[j].generator && list[j].body >= 0) {  // its body's entries only
      int first = 0, last = 0;
      support_of(model, list[j], first, last);
      list[j].generator(q, ws.map_probe);
      for (int k = first; k < last; ++k) {
        after += ws.map_probe[k] * p_new[k];
        ws.map_probe[k] = 0.0;
      }
    } else if (list[j].generator) {
      list[j].generator(q, ws.map_probe);
      after = ws.map_probe.dot(p_new);
      ws.map_probe.setZero();
    } else {
      after = list[j].map(q, p_new);
    }
    // Round-off: the products over the L entries the map reads, and the projection that made p_r,
    // err by about sqrt(L) eps of the scale (a 10^4-ball chain's roll_x, L = 5 10^4: 0.6 of
    // that); a map that is not linear in p moves by O(1) of it.
    int lo = 0, hi = model.num_velocities();
    if (list[j].generator) support_of(model, list[j], lo, hi);
    const double tolerance = 64.0 * kEps * std::sqrt(static_cast<double>(std::max(1, hi - lo)));
    if (!(std::abs(after - ws.map_values[j]) <= tolerance * ws.map_values[r + j]))
      return ws.fail(Status::RestartFailed,
                     "momentum map '%s' would change from %.17g to %.17g: a momentum map must be "
                     "linear in p (J = <p, xi_Q(q)>); restart with RestartMode::Never or fix the map",
                     list[j].name.c_str(), ws.map_values[j], after);
  }
  return Status::Ok;
}

// Whether a r^(interval / k) <= tolerance / 4 for r > 1, checked through the integer power
// r^ceil(interval / k) (at most 64 products): the amplitude predicted `interval` steps ahead is
// then below half the tolerance by a factor 2, more than round-off, so the logarithms of
// plan_after_measurement could not shorten the interval. Saves a pow and two logs per
// measurement on a small model, where they cost a third of a step.
bool prediction_far_below(double a, double r, long interval, long k, double tolerance) {
  const long m = (interval + k - 1) / k;
  if (m > 64) return false;
  double predicted = a;
  for (long i = 0; i < m && predicted <= tolerance; ++i) predicted *= r;
  return 4.0 * predicted <= tolerance;
}

}  // namespace

int plan_map_slots(const Model& model, std::vector<int>& slot, std::vector<int>& overlap_ptr,
                   std::vector<int>& overlap) {
  const auto& maps = model.momentum_maps();
  const auto& mass = model.mass();
  const int r = static_cast<int>(maps.size());
  slot.assign(3 * static_cast<std::size_t>(r), 0);
  overlap_ptr.assign(static_cast<std::size_t>(r) + 1, 0);
  overlap.clear();
  if (r == 0 || model.num_velocities() == 0) return 0;
  // For each block of M, the planned directions whose slots cover it (a full direction is in
  // every block's list: O(n) for each of the few of them).
  std::vector<std::vector<int>> cover(static_cast<std::size_t>(mass.num_blocks()));
  std::vector<int> seen(static_cast<std::size_t>(r), -1);
  std::priority_queue<int, std::vector<int>, std::greater<int>> candidates;
  int pool = 0;
  for (int j = 0; j < r; ++j) {
    int lo = 0, hi = 0;
    support_of(model, maps[j], lo, hi);
    auto gather = [&](int from, int to) {  // the directions covering blocks of [from, to)
      for (int k = from; k < to;) {
        const int block = mass.block_of(k);
        for (int i : cover[static_cast<std::size_t>(block)])
          if (seen[static_cast<std::size_t>(i)] != j) {
            seen[static_cast<std::size_t>(i)] = j;
            candidates.push(i);
          }
        k = mass.block_offset(block) + mass.block_size(block);
      }
    };
    gather(lo, hi);
    // In order, as the Gram-Schmidt meets them: an earlier direction counts when it overlaps the
    // slot grown so far (one that only a later growth reaches was passed by then).
    int last = -1;
    while (!candidates.empty()) {
      const int i = candidates.top();
      candidates.pop();
      if (i < last) continue;
      last = i;
      overlap.push_back(i);
      const int ilo = slot[3 * i + 1], ihi = slot[3 * i + 2];
      if (ilo < lo) gather(ilo, lo);
      if (ihi > hi) gather(hi, ihi);
      lo = std::min(lo, ilo);
      hi = std::max(hi, ihi);
    }
    overlap_ptr[static_cast<std::size_t>(j) + 1] = static_cast<int>(overlap.size());
    slot[3 * j] = pool;
    slot[3 * j + 1] = lo;
    slot[3 * j + 2] = hi;
    pool += hi - lo;
    for (int k = lo; k < hi;) {
      const int block = mass.block_of(k);
      cover[static_cast<std::size_t>(block)].push_back(j);
      k = mass.block_offset(block) + mass.block_size(block);
    }
  }
  return pool;
}

bool plan_after_measurement(const RestartOptions& o, double h, ModeWatch& w, long now, double a) {
  long interval = o.monitor_every;
  // The default tolerance (o.tolerance = 0) gives way to the floor; one the user set does not.
  const bool floored = o.mode == RestartMode::Auto && !(o.tolerance > 0.0);
  double tolerance = std::max(o.tolerance_for(h), floored ? 2.0 * w.floor : 0.0);
  bool probe = false;
  if (floored && w.last_amplitude < 0.0 && now == w.last_step + 1 && a > tolerance) {
    if (w.last_amplitude < -1.0) {  // two restarts in a row could not bring it lower (ModeWatch::floor)
      w.floor = std::max(a, -1.0 - w.last_amplitude);
      tolerance = 2.0 * w.floor;
    } else {
      probe = true;  // restart once more: a floor stays, a mode this one step excited goes
    }
  }
  const bool restart = o.mode == RestartMode::Auto && !(a <= tolerance);
  if (o.mode == RestartMode::Auto) {
    if (!(a <= tolerance)) {
      interval = 1;
    } else if (a > 0.0 && w.last_amplitude > 0.0 &&
               (a <= w.last_amplitude ||  // growth below 1: the interval stays
                prediction_far_below(a, a / w.last_amplitude, interval, now - w.last_step, tolerance))) {
    } else if (a > 0.0) {
      double growth = 2.0;
      if (w.last_amplitude > 0.0) {
        const long k = now - w.last_step;  // pow(r, 1) is r exactly: no call
        const double r = a / w.last_amplitude;
        growth = std::max(1.0, k == 1 ? r : std::pow(r, 1.0 / static_cast<double>(k)));
      }
      // Towards half the tolerance; above a floor towards the tolerance itself, twice the floor:
      // half of it is the floor, which round-off reaches at once (each step was measured).
      const double target = floored && w.floor > 0.0 ? tolerance : 0.5 * tolerance;
      if (growth > 1.0)
        interval = std::min(interval, static_cast<long>(std::log(target / a) / std::log(growth)));
    }
  }
  w.next_step = now + std::max(1L, interval);
  w.last_step = now;
  w.last_amplitude = probe ? -1.0 - a : a;  // the probe's restart keeps it (plan_after_restart)
  return restart;
}

void plan_after_restart(const RestartOptions& o, ModeWatch& w, long now) {
  // A restart: -1, or -1 - a when it probes whether the amplitude a a restart left is a floor
  // (a measurement's amplitude is never negative).
  const bool probe = w.last_step == now && w.last_amplitude < -1.0;
  w.last_step = now;
  if (!probe) w.last_amplitude = -1.0;
  if (o.mode == RestartMode::Auto) w.next_step = now + 1;
}

Status continuous_multiplier_at(const Model& model, Workspace& ws, ConstVecRef q, ConstVecRef p,
                                ConstVecRef applied) {
  const auto& minv = model.inverse_mass();
  // mu(q) and C(q) are cached: the step that arrived at q left them (a fused step its sin/cos).
  Status status = ws.evaluate_one_forms(q);
  if (status != Status::Ok) return status;
  minv.multiply(p.data(), ws.velocity.data());
  status = detail::constraint_bias(model, ws, q, ws.velocity, ws.rhs);
  if (status != Status::Ok) return status;
  if (model.has_applied_force()) {
    minv.multiply(applied.data(), ws.scratch_n.data());
    model.mu_times(ws.mu_values.data(), ws.scratch_n.data(), ws.scratch_m.data());
    ws.rhs += ws.scratch_m;
  }
  if ((status = solve_negated(ws, ws.rhs, ws.lambda_s.data())) != Status::Ok) return status;
  if (!std::isfinite(ws.lambda_s.sum()))
    return ws.fail(Status::NonFiniteState,
                   "the continuous multiplier is not finite (the bias or the force is NaN or Inf): "
                   "check the model's bias and forces, or reduce the step size");
  return Status::Ok;
}

void gap_momentum_half(const Workspace& ws, const State& from, double h, VecRef out) {
  out = (ws.p_half - from.p - (0.5 * h) * from.force) / h;
}

Status gap_offset_multiplier(const Model& model, Workspace& ws, const State& from, double h) {
  Status status = ws.evaluate_one_forms(ws.q_next);  // cached, as in continuous_multiplier_at
  if (status != Status::Ok) return status;
  gap_momentum_half(ws, from, h, ws.scratch_n);
  model.inverse_mass().multiply(ws.scratch_n.data(), ws.scratch_n2.data());
  model.mu_times(ws.mu_values.data(), ws.scratch_n2.data(), ws.rhs.data());
  return ws.solve(ws.rhs.data(), ws.offset_multiplier.data());
}

double parasitic_of(const Model& model, Workspace& ws, ConstVecRef p, ConstVecRef lambda, double h,
                    bool gap_offset) {
  ws.scratch_m = lambda - ws.lambda_s;
  if (gap_offset) ws.scratch_m += ws.offset_multiplier;
  model.mu_transpose_times(ws.mu_values.data(), ws.scratch_m.data(), ws.scratch_n.data());
  const double mode = inverse_mass_dot(model, ws.scratch_n, ws.scratch_n, ws.scratch_n2);
  // The denominator (parasitic_scale): p_- = p - (h/2)(mu^T lambda + f) in p_hat, and the kicks.
  model.mu_transpose_times(ws.mu_values.data(), lambda.data(), ws.p_hat.data());
  double kicks = inverse_mass_dot(model, ws.p_hat, ws.p_hat, ws.scratch_n2);
  if (model.has_applied_force()) {
    kicks += inverse_mass_dot(model, ws.applied, ws.applied, ws.scratch_n2);
    ws.p_hat += ws.applied;
  }
  ws.p_hat = p - (0.5 * h) * ws.p_hat;
  const double arriving = inverse_mass_dot(model, ws.p_hat, ws.p_hat, ws.scratch_n2);
  return parasitic_amplitude_of(mode, arriving, kicks, h);
}

Status rescaled_restart(const Model& model, Workspace& ws, ConstVecRef q, VecRef p, VecRef lambda,
                        VecRef force, ConstVecRef applied, double h, bool gap_offset) {
  const auto& minv = model.inverse_mass();
  const bool forced = model.has_applied_force();
  const bool maps = !model.momentum_maps().empty();
  const double half = 0.5 * h;
  Status status = Status::Ok;

  auto apply_minv = [&minv](ConstVecRef x, VecRef y) { minv.multiply(x.data(), y.data()); };
  // V(q_{k-1}) for the arriving p_- (v_- = M^-1 p_-): q_k - h v_- on flat models, the step
  // back through the Legendre transforms with rigid bodies.
  const RotationLagrangian rotation = ws.rotation();
  auto previous = [&](ConstVecRef p_minus, VecRef v_minus) {
    if (!model.has_rigid_bodies()) {
      v_minus = q - h * v_minus;
      return model.potential(v_minus);
    }
    return previous_potential(model, rotation, h, q, p_minus, v_minus, ws.scratch_q);
  };
  // The energy to keep: that of the arriving post-momentum, with the potential averaged over
  // q_k and q_{k-1} (what diagnose() reports).
  ws.scratch_n2 = p - half * force;
  const double target = arriving_energy(model, q, ws.scratch_n2, apply_minv, ws.scratch_n, previous);

  // lambda_s = lambda_F + lambda_B(p): split off the force's part, which does not scale.
  if (forced) {
    minv.multiply(applied.data(), ws.scratch_n.data());
    model.mu_times(ws.mu_values.data(), ws.scratch_n.data(), ws.rhs.data());
    if ((status = solve_negated(ws, ws.rhs, ws.lambda_f.data())) != Status::Ok) return status;
    ws.lambda_s -= ws.lambda_f;
  }
  // Now lambda_s holds lambda_B(p~) = lambda_0 + lambda_1 + lambda_2 (the bias part).
  Vector& a = ws.p_hat;
  Vector& c = ws.p_half;
  Vector& lambda_const = ws.scratch_m;  // lambda_F + lambda_0 (- x)
  bool all_seen = false;
  if (maps) {
    if ((status = split_by_maps(model, ws, q, p)) != Status::Ok) return status;
    // When the momentum maps see all of p~ (their generators span D: a single Chaplygin ball),
    // p~ is theirs to keep, and with it (1/2) p~^T M^-1 p~: E_post = that + (h^2/8) |lambda~|_C^2
    // (f = 0) fixes |lambda~|_C. The restart can only turn lambda~ towards lambda_s on that
    // ellipsoid: lambda~ <- lambda_F + s^2 lambda_B, p~ unchanged (docs/design.md section 10.3).
    all_seen = inverse_mass_dot(model, ws.map_rest, ws.map_rest, ws.scratch_n2) <=
               64.0 * kEps * inverse_mass_dot(model, p, p, ws.scratch_n2);
  }
  if (maps && !all_seen) {
    // Polarisation of the bias: B(v_J + s v_r) = B(v_J) + s B_1 + s^2 B_2 from s = 0, 1, -1.
    if ((status = detail::constraint_bias(model, ws, q, ws.scratch_n, ws.rhs)) != Status::Ok) return status;
    if ((status = solve_negated(ws, ws.rhs, ws.map_lambda0.data())) != Status::Ok) return status;
    ws.scratch_n = 2.0 * ws.scratch_n - ws.velocity;  // v_J - v_r
    if ((status = detail::constraint_bias(model, ws, q, ws.scratch_n, ws.rhs)) != Status::Ok) return status;
    if ((status = solve_negated(ws, ws.rhs, ws.scratch_m.data())) != Status::Ok) return status;
    ws.map_lambda1 = 0.5 * (ws.lambda_s - ws.scratch_m);
    ws.lambda_s = 0.5 * (ws.lambda_s + ws.scratch_m) - ws.map_lambda0;  // lambda_2
    lambda_const = ws.map_lambda0;
  } else {
    lambda_const.setZero();  // lambda_0 = lambda_1 = 0, lambda_2 = lambda_B
  }
  if (forced) lambda_const += ws.lambda_f;
  if (gap_offset) lambda_const -= ws.offset_multiplier;

  // p_-(s) = a + s b + s^2 c.
  model.mu_transpose_times(ws.mu_values.data(), lambda_const.data(), a.data());
  if (forced) a += applied;
  a *= -half;
  if (all_seen) {  // p_-(s) = a + s^2 c: p~ stays
    a += p;
    ws.map_linear.setZero();
  } else if (maps) {
    a += p - ws.map_rest;
    model.mu_transpose_times(ws.mu_values.data(), ws.map_lambda1.data(), ws.map_linear.data());
    ws.map_linear = ws.map_rest - half * ws.map_linear;
  }
  ConstVecRef b = maps ? ConstVecRef(ws.map_linear) : ConstVecRef(p);
  model.mu_transpose_times(ws.mu_values.data(), ws.lambda_s.data(), c.data());
  c *= -half;

  double s = 1.0, plain = 0.0;
  if (!scale_keeping_energy(model, q, a, b, c, target, apply_minv, ws.scratch_n, ws.scratch_n2, previous, s, plain)) {
    if (!std::isfinite(plain))  // not the restarts' fault: "restart less often" misled (v0 = 1e100)
      return ws.fail(Status::RestartFailed, NONHOLO_OVERFLOWING_RESTART, target, plain);
    return ws.fail(Status::RestartFailed,
                   all_seen ? "no multiplier keeps the post-momentum energy %.17g (energy change of the plain "
                              "restart %.3g) where the momentum maps fix p~: restart less often or not at all "
                              "(RattleOptions::restart, --restart)"
                            : "no rescale of p~ keeps the post-momentum energy %.17g (energy change of the plain "
                              "restart %.3g): restart less often or not at all (RattleOptions::restart, --restart)",
                   target, plain);
  }

  // The new momentum; with momentum maps, checked before anything is written.
  if (all_seen) {
    lambda = lambda_const + (s * s) * ws.lambda_s;
  } else if (maps) {
    ws.map_linear = p + (s - 1.0) * ws.map_rest;
    if ((status = maps_unchanged(model, ws, q, ws.map_linear)) != Status::Ok) return status;
    p = ws.map_linear;
    lambda = lambda_const + s * ws.map_lambda1 + (s * s) * ws.lambda_s;
  } else {
    p *= s;
    lambda = lambda_const + (s * s) * ws.lambda_s;
  }
  model.mu_transpose_times(ws.mu_values.data(), lambda.data(), force.data());
  if (forced) force += applied;
  return Status::Ok;
}


Status project_energy(const Model& model, Workspace& ws, ConstVecRef q, VecRef p, double target) {
  const bool maps = !model.momentum_maps().empty() && model.num_one_forms() > 0;
  Status status = ws.evaluate_one_forms(q);  // cached; see continuous_multiplier_at
  if (status != Status::Ok) return status;
  double kept = 0.0, scaled = 0.0;  // kinetic energies of p_J and p_r
  if (maps) {
    if ((status = split_by_maps(model, ws, q, p)) != Status::Ok) return status;
    ws.map_linear = p - ws.map_rest;  // p_J; scratch_n holds v_J = M^-1 p_J
    kept = 0.5 * ws.map_linear.dot(ws.scratch_n);
    scaled = 0.5 * inverse_mass_dot(model, ws.map_rest, ws.map_rest, ws.scratch_n2);
  } else {
    scaled = 0.5 * inverse_mass_dot(model, p, p, ws.scratch_n2);
  }
  const double potential = model.potential(q);
  const double want = target - potential - kept;
  const double tiny = 8.0 * kEps * (std::abs(target) + std::abs(potential) + kept + scaled);
  if (std::abs(want - scaled) <= tiny) return Status::Ok;
  if (maps && scaled <= 64.0 * kEps * (kept + scaled)) return Status::Ok;  // the maps fix p~ (and its energy)
  if (!(want > 0.0) || !(scaled > 0.0) || !std::isfinite(want / scaled))
    return ws.fail(Status::RestartFailed,
                   "the energy of p~ cannot be brought back to %.17g (potential %.17g, kinetic energy %.17g "
                   "of which the momentum maps keep %.17g): the composed step is too large for this "
                   "motion: reduce the step size, or turn the restarts off (RestartMode::Never)",
                   target, potential, kept + scaled, kept);
  const double s = std::sqrt(want / scaled);
  if (maps) {
    ws.map_linear = p + (s - 1.0) * ws.map_rest;
    if ((status = maps_unchanged(model, ws, q, ws.map_linear)) != Status::Ok) return status;
    p = ws.map_linear;
  } else {
    p *= s;
  }
  return Status::Ok;
}

}  // namespace detail

namespace {

// For a state between steps: the workspace's checks, then C(q) factorised, f(t, q) in
// ws.applied and lambda_s(q, p~) in ws.lambda_s (continuous_multiplier_at).
Status multiplier_of_state(const Model& model, Workspace& ws, const State& s, double h, double min_pivot_ratio) {
  if (&ws.model() != &model)
    return ws.fail(Status::WorkspaceMismatch, "the workspace was built for another model: build one for this model");
  if (!(h > 0.0) || !std::isfinite(h))
    return ws.fail(Status::InvalidStepSize, "step size h = %g must be positive and finite", h);
  if (model.num_one_forms() == 0) return Status::Ok;
  const Status status = ws.factorize_at(s.q, min_pivot_ratio);
  if (status != Status::Ok) return status;
  if (model.has_applied_force()) model.applied_force(s.t, s.q, ws.applied, ws.scratch_n);
  return detail::continuous_multiplier_at(model, ws, s.q, s.p, ws.applied);
}

}  // namespace

Status detail::parasitic_amplitude(const Model& model, Workspace& ws, const State& s, double h, double& amplitude,
                                   double min_pivot_ratio) {
  amplitude = 0.0;
  return guard_callbacks(ws, [&] {
    const Status status = multiplier_of_state(model, ws, s, h, min_pivot_ratio);
    if (status == Status::Ok && model.num_one_forms() > 0)
      amplitude = parasitic_of(model, ws, s.p, s.lambda, h, false);
    return status;
  });
}

Status parasitic_amplitude(const Model& model, Workspace& ws, const State& s, double h, double& amplitude,
                           double min_pivot_ratio) {
  return with_flag(ws.busy_flag(),
                   [&] { return detail::parasitic_amplitude(model, ws, s, h, amplitude, min_pivot_ratio); });
}

Status restart(const Model& model, Workspace& ws, State& s, const RattleOptions& options) {
  const BusyEntry entry(ws.busy_flag());
  if (!entry.held()) return Status::WorkspaceBusy;
  return detail::guard_callbacks(ws, [&] {
    Status status = multiplier_of_state(model, ws, s, options.h, options.min_pivot_ratio);
    if (status != Status::Ok || model.num_one_forms() == 0) return status;
    status = detail::rescaled_restart(model, ws, s.q, s.p, s.lambda, s.force, ws.applied, options.h, false);
    if (status == Status::Ok) ++s.restarts;
    return status;
  });
}

}  // namespace nonholo
