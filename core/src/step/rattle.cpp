// The nonholonomic RATTLE step (docs/design.md section 2):
//   p_{k+1/2} = p~_k + (h/2)(f_k + mu_k^T lambda~_k)      (state.force holds the bracket)
//   q_{k+1}   = q_k + h M^-1 p_{k+1/2}
//   p^        = p_{k+1/2} + (h/2) f_{k+1}
//   C(q_{k+1}) lambda~_{k+1} = -(2/h) mu_{k+1} M^-1 p^
//   p~_{k+1}  = p^ + (h/2) mu_{k+1}^T lambda~_{k+1}
// In holonomic mode the first half kick also gets (h/2) mu_k^T dlambda so that g(q_{k+1}) = 0
// (docs/design.md section 4); see enforce_gaps. Before the new state is committed, control_mode
// measures the period-2 mode there and restarts the multipliers (docs/design.md section 8,
// restart.cpp) as RattleOptions::restart asks. Orders 4 and 6 compose this step with signed
// substeps (detail::advance): composed_step.cpp. The options' names and checks are in
// base/rattle_options.cpp.
#include <nonholo/rattle.hpp>

#include <nonholo/dynamics.hpp>
#include <nonholo/restart.hpp>

#include <algorithm>
#include <cmath>
#include <limits>

#include "base/callback_guard.hpp"
#include "base/option_checks.hpp"
#include "model/element_set.hpp"
#include "step/chain/ball_chain_band.hpp"
#include "step/chain/chain_sweep.hpp"
#include "step/rattle_internal.hpp"
#include "step/restart_internal.hpp"
#include "step/rigid/drift.hpp"

namespace nonholo {

namespace {

// What would fix a position iteration that did not converge: the period-2 mode when it
// carries a visible share of the momentum (it makes the multiplier, hence the first half
// kick, swing from step to step), round-off when the gap is already near the tolerance,
// otherwise a step too large for the Newton iteration frozen at q_k.
Status gap_failure(const Model& model, Workspace& ws, const State& s, const RattleOptions& o, double h,
                   double worst, int iterations, double tolerance) {
  double mode = 0.0;  // measured at the step's start, where C(q_k) is factorised
  if (detail::parasitic_amplitude(model, ws, s, std::abs(h), mode, 0.0) == Status::Ok && mode >= 1e-2) {
    if (o.restart.mode == RestartMode::Auto)
      return ws.fail(Status::GapNotConverged,
                     "hitch gap %.3g after %d corrections (tolerance %.3g) from t = %.17g: the period-2 "
                     "mode carries %.2g of the momentum: restart more often (lower restart_tolerance, "
                     "monitor_every = 1) or reduce the step size (h = %g)",
                     worst, iterations, tolerance, s.t, mode, std::abs(h));
    return ws.fail(Status::GapNotConverged,
                   "hitch gap %.3g after %d corrections (tolerance %.3g) from t = %.17g: the period-2 "
                   "mode carries %.2g of the momentum: turn on multiplier restarts (--restart auto, "
                   "RestartMode::Auto); a smaller step does not help",
                   worst, iterations, tolerance, s.t, mode);
  }
  if (worst <= 100.0 * tolerance)
    return ws.fail(Status::GapNotConverged,
                   "hitch gap %.3g after %d corrections (tolerance %.3g) from t = %.17g: the iteration "
                   "stalls at round-off: raise gap_tolerance",
                   worst, iterations, tolerance, s.t);
  return ws.fail(Status::GapNotConverged,
                 "hitch gap %.3g after %d corrections (tolerance %.3g) from t = %.17g: the step is too "
                 "large for the position iteration: reduce the step size (h = %g)",
                 worst, iterations, tolerance, s.t, std::abs(h));
}

// Holonomic mode. On entry ws.p_half and ws.q_next are the plain first half kick and drift
// (the common chain's first gap pass computes them); on success g(q_next) = 0. Each correction solves C(q_k) dlambda = -(2/h^2) [g; 0] (hitch
// rows get -g, the other rows 0) and applies p_half += (h/2) mu_k^T dlambda, which moves
// q_next by (h^2/2) M^-1 mu_k^T dlambda: mu_k of that move is -g on the hitch rows (Newton
// with the Jacobian frozen at q_k, converging at a rate O(h |thetadot|)) and 0 on the other
// rows, so mu_k (q_{k+1} - q_{k-1}) = 0 still holds for them.
Status enforce_gaps(const Model& model, Workspace& ws, const State& s, const RattleOptions& o, double h) {
  // A chain of knife edges and hitches: two passes over the bodies per correction
  // (chain_passes.cpp), forward (gaps and forward substitution) and backward (back
  // substitution, correction, the next gaps); the last leaves sin/cos of q_{k+1} for the sweep.
  // Its corrections take mu(q_k)'s rows from sin/cos of q_k, moved to chain_sincos_prev.
  const bool chain = ws.fused() && model.element_set()->hitched_chain;
  Status status = Status::Ok;
  if (!chain || !ws.chain_factor_holds(s.q)) {  // a fused step to q_k left both C(q_k) and them
    // The corrections read C(q_k)'s factorisation row by row: in natural order.
    if ((status = ws.factorize_serial_at(s.q, o.min_pivot_ratio)) != Status::Ok) return status;
    if (chain) {
      detail::chain_sincos_of(model, s.q, ws.chain_sincos);
      ws.sincos_computed_for_key();
    }
  }
  if (chain) {
    ws.chain_sincos.swap(ws.chain_sincos_prev);  // pointers only
    ws.forget_sincos();
  }
  const double scale = -2.0 / (h * h);
  double* x = ws.scratch_m.data();
  double size = 0.0, worst = 0.0;
  if (chain)
    worst = detail::chain_gap_forward(model, ws, s, h, scale, x, size);
  else
    size = ws.q_next.lpNorm<Eigen::Infinity>();
  const double floor = 16.0 * std::numeric_limits<double>::epsilon() * size;
  if (floor > o.gap_tolerance_limit)
    return ws.fail(Status::GapNotConverged,
                   "coordinates reach |q| = %.3g at t = %.17g: their round-off (16 eps |q| = %.3g) exceeds "
                   "gap_tolerance_limit %.3g, so no hitch can be closed; move the scene nearer the origin, use "
                   "larger length units, or reduce the step size if the motion ran away",
                   size, s.t, floor, o.gap_tolerance_limit);
  const double tolerance = std::max(o.gap_tolerance, floor);
  const auto& rows = model.holonomic_rows();
  const int count = model.num_holonomic();
  for (int it = 0;; ++it) {
    if (!chain) {  // the chain's gaps came with its last pass
      model.gap(ws.q_next, ws.gap);
      worst = ws.gap.lpNorm<Eigen::Infinity>();
    }
    if (!std::isfinite(worst))
      return ws.fail(Status::NonFiniteState, "hitch gap is %g after %d corrections", worst, it);
    if (worst <= tolerance) {
      ws.gap_iterations = it;
      return Status::Ok;
    }
    if (it == o.max_gap_iterations) return gap_failure(model, ws, s, o, h, worst, it, tolerance);
    if (chain) {
      if (it > 0) detail::chain_forward_substitute(ws, x);
      worst = detail::chain_correct_backward(model, ws, x, h, scale);
      continue;
    }
    ws.rhs.setZero();
    for (int j = 0; j < count; ++j) ws.rhs[rows[j]] = scale * ws.gap[j];
    if ((status = ws.solve(ws.rhs.data(), x)) != Status::Ok) return status;
    model.mu_transpose_times(ws.mu_values.data(), x, ws.scratch_n.data());
    ws.p_half += (0.5 * h) * ws.scratch_n;
    if (model.has_rigid_bodies()) {  // the drift is not linear in p_half: take it again
      if ((status = detail::rigid_drift(model, ws, s.q, h, o.rotation, s.t)) != Status::Ok) return status;
      continue;
    }
    model.inverse_mass().multiply(ws.scratch_n.data(), ws.scratch_n2.data());
    ws.q_next += (0.5 * h * h) * ws.scratch_n2;
  }
}

// p_half = p~_k + (h/2) force, velocity = M^-1 p_half (unless not `with_velocity`), q_next =
// q_k + h velocity: one pass when M is diagonal.
void kick_drift(const sparse::BlockDiagonal& minv, double h, const double* q, const double* p,
                const double* force, Workspace& ws, bool with_velocity = true) {
  const int n = minv.size();
  const double half = 0.5 * h;
  double* ph = ws.p_half.data();
  double* v = ws.velocity.data();
  double* qn = ws.q_next.data();
  if (minv.is_diagonal()) {
    const double* w = minv.diagonal();
    if (!with_velocity) {  // the fused chain step computes its velocities itself: one stream less
      for (int i = 0; i < n; ++i) {
        ph[i] = p[i] + half * force[i];
        qn[i] = q[i] + h * (w[i] * ph[i]);  // as below, to the bit
      }
      return;
    }
    for (int i = 0; i < n; ++i) {
      ph[i] = p[i] + half * force[i];
      v[i] = w[i] * ph[i];
      qn[i] = q[i] + h * v[i];
    }
    return;
  }
  for (int i = 0; i < n; ++i) ph[i] = p[i] + half * force[i];
  minv.multiply(ph, v);
  for (int i = 0; i < n; ++i) qn[i] = q[i] + h * v[i];
}

// After the step's candidate state at t_{k+1} is complete (ws.q_next, p_next, lambda,
// force_next, applied, C(q_{k+1}) factorised): measure the parasitic amplitude when it is
// due, restart when options ask, and plan the next measurement in `watch`. `fused`: the step
// was a chain sweep, measured in one pass from its data (chain_measure.cpp); `knives`: a
// knife_sweep, measured in one (knife_mode.cpp).
Status control_mode(const Model& model, Workspace& ws, const State& s, const RestartOptions& o, double h,
                    ModeWatch& watch, bool fused, bool knives) {
  ws.parasitic = std::numeric_limits<double>::quiet_NaN();
  ws.restarted = false;
  const long now = s.steps + 1;
  const bool gap_offset = ws.gap_iterations > 0;
  // In holonomic mode the start's lambda~_0 = lambda(0) lacks the offset -dlambda/2; the first
  // step absorbs the difference (it lies in the hitch directions), so a measurement there
  // would report a transient that is not a mode.
  const bool measure = detail::measurement_due(o, watch, now) && !(gap_offset && s.steps == 0);
  bool restart = detail::periodic_restart_due(o, now);
  if (!measure && !restart) return Status::Ok;
  Status status = Status::Ok;
  // Whether continuous_multiplier_at has left mu(q_{k+1}) and lambda_s for a restart.
  bool multiplier = false, measured = false;
  if (measure && knives) {
    measured = detail::knife_chain_parasitic(model, ws, ws.p_next, ws.lambda, h, ws.parasitic);
  } else if (measure && fused) {  // the sweeps just left sin/cos and C of q_{k+1}: one pass
    if ((status = detail::chain_measure(model, ws, ws.p_next.data(), ws.lambda.data(), h, gap_offset ? &s : nullptr,
                                        ws.parasitic)) != Status::Ok)
      return status;
    measured = true;
  }
  // lambda_s at q_{k+1}, and the gap corrections' offset (restart_internal.hpp).
  auto multiplier_and_offset = [&] {
    Status st = detail::continuous_multiplier_at(model, ws, ws.q_next, ws.p_next, ws.applied);
    if (st == Status::Ok && gap_offset) st = detail::gap_offset_multiplier(model, ws, s, h);
    multiplier = true;
    return st;
  };
  if (!measured) {
    if ((status = multiplier_and_offset()) != Status::Ok) return status;
    if (measure) ws.parasitic = detail::parasitic_of(model, ws, ws.p_next, ws.lambda, h, gap_offset);
  }
  if (measure) restart = detail::plan_after_measurement(o, h, watch, now, ws.parasitic) || restart;
  if (restart) {
    if (!multiplier && (status = multiplier_and_offset()) != Status::Ok) return status;
    status = detail::rescaled_restart(model, ws, ws.q_next, ws.p_next, ws.lambda, ws.force_next, ws.applied, h,
                                      gap_offset);
    if (status != Status::Ok) return status;
    ws.restarted = true;
    detail::plan_after_restart(o, watch, now);
  }
  return Status::Ok;
}

}  // namespace

namespace detail {

Status finish_step(const Model& model, Workspace& ws, State& s, const RattleOptions& options, double h,
                   double t_next, ModeWatch* watch, double check, bool fused, bool knives);

Status advance(const Model& model, Workspace& ws, State& s, const RattleOptions& options, double h, double t_next,
               ModeWatch* watch) {
  const int n = model.num_coordinates(), m = model.num_one_forms();
  const double half = 0.5 * h;
  const auto& minv = model.inverse_mass();

  ws.step_diagnostics.q = nullptr;
  ws.gap_iterations = 0;
  const bool holonomic = options.hitch == HitchMode::Holonomic && model.num_holonomic() > 0;
  double check = 0.0;  // NaN or Inf anywhere in the new state makes this non-finite
  if (ws.fused()) {  // a chain of elements: two sweeps over the bodies (chain_sweep.cpp)
    const FlushSubnormals flush(model.num_bodies() >= kFlushSubnormalsFrom);
    if (holonomic) {  // the common chain's gap pass kicks and drifts (chain_gap_forward)
      if (!model.element_set()->hitched_chain) kick_drift(minv, h, s.q.data(), s.p.data(), s.force.data(), ws, false);
      const Status status = enforce_gaps(model, ws, s, options, h);
      if (status != Status::Ok) return status;
    }
    const Status status = chain_sweep(model, ws, s, options, h, t_next, holonomic, check);
    if (status != Status::Ok) return status;
    return finish_step(model, ws, s, options, h, t_next, watch, check, true, knife_sweep(model, ws, holonomic));
  }
  // Half kick with the forces at t_k, then drift (with rigid bodies per body, rigid/drift.cpp:
  // the momentum arrives at q_{k+1} as p_arrive, turned by W^T; velocity = M^-1 of it).
  const bool rigid = model.has_rigid_bodies();
  if (rigid) {
    const Status status = detail::rigid_drift(model, ws, s.q, h, options.rotation, s.t, &s);
    if (status != Status::Ok) return status;
  } else {
    kick_drift(minv, h, s.q.data(), s.p.data(), s.force.data(), ws);
  }
  const Vector& carried = rigid ? ws.p_arrive : ws.p_half;
  if (holonomic) {
    const Status status = enforce_gaps(model, ws, s, options, h);
    if (status != Status::Ok) return status;
    if (!rigid) minv.multiply(ws.p_half.data(), ws.velocity.data());
  }
  // Unconstrained half kick with the applied force at t_{k+1}.
  if (model.has_applied_force()) {
    model.applied_force(t_next, ws.q_next, ws.applied, ws.scratch_n);
    ws.p_hat = carried + half * ws.applied;
    minv.multiply(ws.p_hat.data(), ws.velocity.data());
  } else {
    // p^ = p_half (p_arrive): velocity already holds M^-1 p^; applied stays zero
  }
  const bool forced = model.has_applied_force();
  const double* ph = forced ? ws.p_hat.data() : carried.data();

  // Constraint half kick: the multipliers that put p~_{k+1} in the annihilator of D.
  if (m > 0 && detail::ball_chain_kick_applies(model, ws)) {  // two passes (ball_chain_band.cpp)
    const Status status = detail::ball_chain_kick(model, ws, ph, forced ? ws.applied.data() : nullptr, h,
                                                  options.min_pivot_ratio, check);
    if (status != Status::Ok) return status;
  } else if (m > 0) {
    Status status = ws.evaluate_one_forms(ws.q_next);
    if (status == Status::Ok) status = ws.factorize(options.min_pivot_ratio);
    if (status != Status::Ok) return status;
    model.mu_times(ws.mu_values.data(), ws.velocity.data(), ws.rhs.data());
    ws.rhs *= -2.0 / h;
    if ((status = ws.solve(ws.rhs.data(), ws.lambda.data())) != Status::Ok) return status;
    model.mu_transpose_times(ws.mu_values.data(), ws.lambda.data(), ws.force_next.data());
    // force_next = f_{k+1} + mu^T lambda, p~_{k+1} = p^ + (h/2) mu^T lambda, in one pass.
    double* fn = ws.force_next.data();
    double* pn = ws.p_next.data();
    const double* fa = ws.applied.data();
    const double* qn = ws.q_next.data();
    if (rigid) {  // q has n_q entries, not n
      for (int i = 0; i < n; ++i) {
        pn[i] = ph[i] + half * fn[i];
        if (forced) fn[i] += fa[i];
        check += pn[i] + fn[i];
      }
      check += ws.q_next.sum();
    } else if (forced) {
      for (int i = 0; i < n; ++i) {
        pn[i] = ph[i] + half * fn[i];
        fn[i] += fa[i];
        check += qn[i] + pn[i] + fn[i];
      }
    } else {
      for (int i = 0; i < n; ++i) {
        pn[i] = ph[i] + half * fn[i];
        check += qn[i] + pn[i] + fn[i];
      }
    }
  } else {
    ws.force_next = ws.applied;
    ws.p_next = forced ? ws.p_hat : carried;
    check = ws.q_next.sum() + ws.p_next.sum() + ws.force_next.sum();
  }
  return finish_step(model, ws, s, options, h, t_next, watch, check, false, false);
}

// The new state is in ws.q_next, p_next, lambda, force_next: check it, control the period-2
// mode, commit.
Status finish_step(const Model& model, Workspace& ws, State& s, const RattleOptions& options, double h,
                   double t_next, ModeWatch* watch, double check, bool fused, bool knives) {
  const int m = model.num_one_forms();
  if (!std::isfinite(check))
    return ws.fail(Status::NonFiniteState,
                   "the step from t = %.17g produced NaN or Inf: reduce the step size (h = %g) or "
                   "check the model's forces",
                   s.t, std::abs(h));

  // The period-2 mode at t_{k+1} (restart.hpp): measure, then restart as asked.
  ws.parasitic = m > 0 ? std::numeric_limits<double>::quiet_NaN() : 0.0;
  ws.restarted = false;
  const long now = s.steps + 1;  // most steps have nothing due: no call
  if (m > 0 && watch &&
      (measurement_due(options.restart, *watch, now) || periodic_restart_due(options.restart, now))) {
    const Status status = control_mode(model, ws, s, options.restart, h, *watch, fused, knives);
    if (status != Status::Ok) return status;
  }

  s.t = t_next;
  // Commit by exchanging buffers (no copy: a million-body state is 72 MB).
  if (fused && !ws.restarted) ws.step_diagnostics.q = ws.q_next.data();  // the buffer s.q gets
  s.q.swap(ws.q_next);
  s.p.swap(ws.p_next);
  s.lambda.swap(ws.lambda);
  s.force.swap(ws.force_next);
  return Status::Ok;
}

}  // namespace detail

Status step(const Model& model, Workspace& ws, State& s, const RattleOptions& options) {
  const BusyEntry entry(ws.busy_flag());
  if (!entry.held()) return Status::WorkspaceBusy;
  const int n = model.num_velocities(), nq = model.num_configuration(), m = model.num_one_forms();
  if (&ws.model() != &model)
    return ws.fail(Status::WorkspaceMismatch, "the workspace was built for another model: build one for this model");
  const double h = options.h;
  if (!(h > 0.0) || !std::isfinite(h))
    return ws.fail(Status::InvalidStepSize, "step size h = %g must be positive and finite", h);
  if (s.q.size() != nq || s.p.size() != n || s.force.size() != n || s.lambda.size() != m)
    return ws.fail(Status::SizeMismatch,
                   "state sizes q %ld, p %ld, force %ld, lambda %ld; the model needs %d, %d, %d, %d: "
                   "create the state for this model (start_from_velocity)",
                   static_cast<long>(s.q.size()), static_cast<long>(s.p.size()),
                   static_cast<long>(s.force.size()), static_cast<long>(s.lambda.size()), nq, n, n, m);
  if (model.has_configuration_metric())
    return ws.fail(Status::MethodNotApplicable,
                   "the explicit step needs a constant metric; use implicit_step (implicit.hpp)");
  if (!ws.options_checked(options)) {
    if (const detail::OptionProblem p = detail::rattle_problem(options))
      return ws.fail(Status::InvalidOptions, "RattleOptions: %s = %g %s", p.what, p.value, p.rule);
    ws.remember_options(options);
  }
  if (options.order != 2 || options.composition != Composition::Auto) {
    const Status status = detail::composed_step(model, ws, s, options);
    ws.step_diagnostics.q = nullptr;  // its end may restart; diagnose_step computes afresh
    return status;
  }

  // Copied in and out at every step: at 40 bytes GCC copies it with `rep movs`, 30% of the
  // batched single sleigh's step (measured).
  static_assert(sizeof(ModeWatch) <= 32, "keep ModeWatch small: the step copies it twice");
  ModeWatch watch = s.watch;
  const Status status = detail::guard_callbacks(
      ws, [&] { return detail::advance(model, ws, s, options, h, s.grid.next(s.t, h), &watch); });
  if (status != Status::Ok) return status;
  s.grid.advance();
  ++s.steps;
  ws.step_diagnostics.steps = s.steps;
  if (ws.restarted) ++s.restarts;
  s.watch = watch;
  ws.clear_message();
  return Status::Ok;
}

}  // namespace nonholo
