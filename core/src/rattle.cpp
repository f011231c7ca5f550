// The nonholonomic RATTLE step (DESIGN.md section 2):
//   p_{k+1/2} = p~_k + (h/2)(f_k + mu_k^T lambda~_k)      (state.force holds the bracket)
//   q_{k+1}   = q_k + h M^-1 p_{k+1/2}
//   p^        = p_{k+1/2} + (h/2) f_{k+1}
//   C(q_{k+1}) lambda~_{k+1} = -(2/h) mu_{k+1} M^-1 p^
//   p~_{k+1}  = p^ + (h/2) mu_{k+1}^T lambda~_{k+1}
// In holonomic mode the first half kick also gets (h/2) mu_k^T dlambda so that g(q_{k+1}) = 0
// (DESIGN.md section 4); see enforce_gaps. Before the new state is committed, control_mode
// measures the period-2 mode there and restarts the multipliers (DESIGN.md section 8,
// restart.cpp) as RattleOptions::restart asks.
#include <nonholo/rattle.hpp>

#include <nonholo/dynamics.hpp>
#include <nonholo/restart.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "option_checks.hpp"
#include "restart_internal.hpp"

namespace nonholo {

const char* to_string(HitchMode mode) {
  return mode == HitchMode::OneForm ? "oneform" : "holonomic";
}

HitchMode hitch_mode_from_string(const std::string& name) {
  if (name == "oneform") return HitchMode::OneForm;
  if (name == "holonomic") return HitchMode::Holonomic;
  throw std::invalid_argument("unknown hitch mode '" + name + "' (valid: oneform, holonomic)");
}

const char* to_string(RestartMode mode) {
  switch (mode) {
    case RestartMode::Never: return "never";
    case RestartMode::Periodic: return "periodic";
    case RestartMode::Auto: return "auto";
  }
  return "unknown";
}

void set_restart(RattleOptions& o, const std::string& spec) {
  if (spec == "auto") {
    o.restart = RestartMode::Auto;
    return;
  }
  if (spec == "0" || spec == "never") {
    o.restart = RestartMode::Never;
    return;
  }
  long k = 0;
  std::size_t used = 0;
  try {
    k = std::stol(spec, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used != spec.size() || used == 0 || k < 1 || k > 1000000000L)
    throw std::invalid_argument("restart '" + spec +
                                "': expected auto, 0 (never) or a number of steps K from 1 to 1e9");
  o.restart = RestartMode::Periodic;
  o.restart_every = static_cast<int>(k);
}

std::string restart_spec(const RattleOptions& o) {
  switch (o.restart) {
    case RestartMode::Never: return "0";
    case RestartMode::Periodic: return std::to_string(o.restart_every);
    case RestartMode::Auto: return "auto";
  }
  return "unknown";
}

void validate(const RattleOptions& options) {
  detail::check_step_size(options.h);
  detail::check_pivot_ratio(options.min_pivot_ratio);
  if (!(options.gap_tolerance > 0.0) || !std::isfinite(options.gap_tolerance))
    detail::reject("gap_tolerance", options.gap_tolerance, "must be positive and finite");
  if (options.max_gap_iterations < 1)
    detail::reject("max_gap_iterations", options.max_gap_iterations, "must be at least 1");
  if (options.restart == RestartMode::Periodic && options.restart_every < 1)
    detail::reject("restart_every", options.restart_every, "must be at least 1 with RestartMode::Periodic");
  if (options.restart_every < 0) detail::reject("restart_every", options.restart_every, "must not be negative");
  if (!(options.restart_tolerance >= 0.0) || !std::isfinite(options.restart_tolerance))
    detail::reject("restart_tolerance", options.restart_tolerance, "must be 0 (h^3) or positive and finite");
  if (options.monitor_every < 0) detail::reject("monitor_every", options.monitor_every, "must be 0 (never) or positive");
  if (options.restart == RestartMode::Auto && options.monitor_every < 1)
    detail::reject("monitor_every", options.monitor_every, "must be at least 1 with RestartMode::Auto");
}

namespace {

// What would fix a position iteration that did not converge: the period-2 mode when it
// carries a visible share of the momentum (it makes the multiplier, hence the first half
// kick, swing from step to step), round-off when the gap is already near the tolerance,
// otherwise a step too large for the Newton iteration frozen at q_k.
Status gap_failure(const Model& model, Workspace& ws, const State& s, const RattleOptions& o, double worst,
                   int iterations, double tolerance) {
  double mode = 0.0;  // measured at the step's start, where C(q_k) is factorised
  if (parasitic_amplitude(model, ws, s, o.h, mode, 0.0) == Status::Ok && mode >= 1e-2) {
    if (o.restart == RestartMode::Auto)
      return ws.fail(Status::GapNotConverged,
                     "hitch gap %.3g after %d corrections (tolerance %.3g) from t = %.17g: the period-2 "
                     "mode carries %.2g of the momentum: restart more often (lower restart_tolerance, "
                     "monitor_every = 1) or reduce the step size (h = %g)",
                     worst, iterations, tolerance, s.t, mode, o.h);
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
                 worst, iterations, tolerance, s.t, o.h);
}

// Holonomic mode. On entry ws.p_half and ws.q_next are the plain first half kick and drift;
// on success g(q_next) = 0. Each correction solves C(q_k) dlambda = -(2/h^2) [g; 0] (hitch
// rows get -g, the other rows 0) and applies p_half += (h/2) mu_k^T dlambda, which moves
// q_next by (h^2/2) M^-1 mu_k^T dlambda: mu_k of that move is -g on the hitch rows (Newton
// with the Jacobian frozen at q_k, converging at a rate O(h |thetadot|)) and 0 on the other
// rows, so mu_k (q_{k+1} - q_{k-1}) = 0 still holds for them.
Status enforce_gaps(const Model& model, Workspace& ws, const State& s, const RattleOptions& o) {
  const double h = o.h;
  Status status = ws.factorize_at(s.q, o.min_pivot_ratio);
  if (status != Status::Ok) return status;
  const auto& rows = model.holonomic_rows();
  const int count = model.num_holonomic();
  const double floor = 16.0 * std::numeric_limits<double>::epsilon() * ws.q_next.lpNorm<Eigen::Infinity>();
  const double tolerance = std::max(o.gap_tolerance, floor);
  ws.gap_multiplier.setZero();
  for (int it = 0;; ++it) {
    model.gap(ws.q_next, ws.gap);
    const double worst = ws.gap.lpNorm<Eigen::Infinity>();
    if (!std::isfinite(worst))
      return ws.fail(Status::NonFiniteState, "hitch gap is %g after %d corrections", worst, it);
    if (worst <= tolerance) {
      ws.gap_iterations = it;
      return Status::Ok;
    }
    if (it == o.max_gap_iterations) return gap_failure(model, ws, s, o, worst, it, tolerance);
    ws.rhs.setZero();
    for (int j = 0; j < count; ++j) ws.rhs[rows[j]] = (-2.0 / (h * h)) * ws.gap[j];
    if ((status = ws.solve(ws.rhs.data(), ws.scratch_m.data())) != Status::Ok) return status;
    ws.gap_multiplier += ws.scratch_m;
    model.mu_transpose_times(ws.mu_values.data(), ws.scratch_m.data(), ws.scratch_n.data());
    ws.p_half += (0.5 * h) * ws.scratch_n;
    model.inverse_mass().multiply(ws.scratch_n.data(), ws.scratch_n2.data());
    ws.q_next += (0.5 * h * h) * ws.scratch_n2;
  }
}

// p_half = p~_k + (h/2) force, velocity = M^-1 p_half, q_next = q_k + h velocity: one pass
// when M is diagonal.
void kick_drift(const sparse::BlockDiagonal& minv, double h, const double* q, const double* p,
                const double* force, Workspace& ws) {
  const int n = minv.size();
  const double half = 0.5 * h;
  double* ph = ws.p_half.data();
  double* v = ws.velocity.data();
  double* qn = ws.q_next.data();
  if (minv.is_diagonal()) {
    const double* w = minv.diagonal();
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

// Automatic restarts: how many steps after a measurement of amplitude a the next one is due.
// The amplitude is predicted from its growth per step g between the last two measurements
// (g = 2 when unknown: where the motion attracts strongly, a whipped trailer, the mode doubles
// per step); the next measurement comes after the most steps, up to `widest`, that keep the
// prediction below half the tolerance, and at the next step once the tolerance is passed.
long measurement_interval(double a, double tolerance, const State::ModeWatch& watch, long now, long widest) {
  if (!(a <= tolerance)) return 1;
  if (!(a > 0.0)) return widest;
  double growth = 2.0;
  if (watch.last_amplitude > 0.0)
    growth = std::max(1.0, std::pow(a / watch.last_amplitude, 1.0 / static_cast<double>(now - watch.last_step)));
  if (growth == 1.0) return widest;
  const double steps = std::log(0.5 * tolerance / a) / std::log(growth);
  return std::max(1L, std::min(widest, static_cast<long>(steps)));
}

// After the step's candidate state at t_{k+1} is complete (ws.q_next, p_next, lambda,
// force_next, applied, C(q_{k+1}) factorised): measure the parasitic amplitude when it is
// due, restart when options ask, and plan the next measurement in `watch` (without automatic
// restarts the measurement only reports, every monitor_every steps).
Status control_mode(const Model& model, Workspace& ws, const State& s, const RattleOptions& o,
                    State::ModeWatch& watch) {
  ws.parasitic = std::numeric_limits<double>::quiet_NaN();
  ws.restarted = false;
  const long now = s.steps + 1;
  const bool automatic = o.restart == RestartMode::Auto;
  const bool gap_offset = ws.gap_iterations > 0;
  // In holonomic mode the start's lambda~_0 = lambda(0) lacks the offset -dlambda/2; the first
  // step absorbs the difference (it lies in the hitch directions), so a measurement there
  // would report a transient that is not a mode.
  const bool measure = o.monitor_every > 0 && now >= watch.next_step && !(gap_offset && s.steps == 0);
  bool restart = o.restart == RestartMode::Periodic && o.restart_every > 0 && now % o.restart_every == 0;
  if (!measure && !restart) return Status::Ok;
  Status status = detail::continuous_multiplier_at(model, ws, ws.q_next, ws.p_next, ws.applied);
  if (status != Status::Ok) return status;
  if (measure) {
    const double a = ws.parasitic = detail::parasitic_of(model, ws, ws.p_next, ws.lambda, o.h, gap_offset);
    const double tolerance = o.parasitic_tolerance();
    if (automatic && !(a <= tolerance)) restart = true;
    watch.next_step = now + (automatic ? measurement_interval(a, tolerance, watch, now, o.monitor_every) : o.monitor_every);
    watch.last_step = now;
    watch.last_amplitude = a;
  }
  if (restart) {
    status = detail::rescaled_restart(model, ws, ws.q_next, ws.p_next, ws.lambda, ws.force_next, ws.applied, o.h,
                                      gap_offset);
    if (status != Status::Ok) return status;
    ws.restarted = true;
    watch.last_step = now;
    watch.last_amplitude = 0.0;  // the mode starts again from its seed: measure it after one step
    if (automatic) watch.next_step = now + 1;
  }
  return Status::Ok;
}

}  // namespace

Status step(const Model& model, Workspace& ws, State& s, const RattleOptions& options) {
  const int n = model.num_coordinates(), m = model.num_one_forms();
  if (&ws.model() != &model)
    return ws.fail(Status::WorkspaceMismatch, "the workspace was built for another model: build one for this model");
  const double h = options.h;
  if (!(h > 0.0) || !std::isfinite(h))
    return ws.fail(Status::InvalidStepSize, "step size h = %g must be positive and finite", h);
  if (s.q.size() != n || s.p.size() != n || s.force.size() != n || s.lambda.size() != m)
    return ws.fail(Status::SizeMismatch,
                   "state sizes q %ld, p %ld, force %ld, lambda %ld; the model needs %d, %d, %d, %d: "
                   "create the state for this model (start_from_velocity)",
                   static_cast<long>(s.q.size()), static_cast<long>(s.p.size()),
                   static_cast<long>(s.force.size()), static_cast<long>(s.lambda.size()), n, n, n, m);
  if (model.has_configuration_metric())
    return ws.fail(Status::MethodNotApplicable,
                   "the explicit step needs a constant metric; use implicit_step (implicit.hpp)");
  const double half = 0.5 * h;
  const double t_next = s.t + h;
  const auto& minv = model.inverse_mass();

  // Half kick with the forces at t_k, then drift.
  kick_drift(minv, h, s.q.data(), s.p.data(), s.force.data(), ws);
  ws.gap_iterations = 0;
  if (options.hitch == HitchMode::Holonomic && model.num_holonomic() > 0) {
    const Status status = enforce_gaps(model, ws, s, options);
    if (status != Status::Ok) return status;
    minv.multiply(ws.p_half.data(), ws.velocity.data());
  }

  // Unconstrained half kick with the applied force at t_{k+1}.
  if (model.has_applied_force()) {
    model.applied_force(t_next, ws.q_next, ws.applied, ws.scratch_n);
    ws.p_hat = ws.p_half + half * ws.applied;
    minv.multiply(ws.p_hat.data(), ws.velocity.data());
  } else {
    // p^ = p_half: velocity already holds M^-1 p^; applied stays zero
  }
  const bool forced = model.has_applied_force();
  const double* ph = forced ? ws.p_hat.data() : ws.p_half.data();

  // Constraint half kick: the multipliers that put p~_{k+1} in the annihilator of D.
  double check = 0.0;  // NaN or Inf anywhere in the new state makes this non-finite
  if (m > 0) {
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
    if (forced) {
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
    ws.p_next = forced ? ws.p_hat : ws.p_half;
    check = ws.q_next.sum() + ws.p_next.sum() + ws.force_next.sum();
  }
  if (!std::isfinite(check))
    return ws.fail(Status::NonFiniteState,
                   "the step from t = %.17g produced NaN or Inf: reduce the step size (h = %g) or "
                   "check the model's forces",
                   s.t, h);

  // The period-2 mode at t_{k+1} (restart.hpp): measure, then restart as asked.
  State::ModeWatch watch = s.watch;
  if (m > 0) {
    const Status status = control_mode(model, ws, s, options, watch);
    if (status != Status::Ok) return status;
  } else {
    ws.parasitic = 0.0;
    ws.restarted = false;
  }

  s.t = t_next;
  // Commit by exchanging buffers (no copy: a million-body state is 72 MB).
  s.q.swap(ws.q_next);
  s.p.swap(ws.p_next);
  s.lambda.swap(ws.lambda);
  s.force.swap(ws.force_next);
  ++s.steps;
  if (ws.restarted) ++s.restarts;
  s.watch = watch;
  ws.clear_message();
  return Status::Ok;
}

}  // namespace nonholo
