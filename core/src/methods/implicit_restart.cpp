// The period-2 mode of the implicit general form (implicit.hpp): the arriving momentum p+ and
// the average p~ = P* p+ differ by a constraint impulse, p+ = p~ - (h/2) mu^T lambda~, and
// lambda~ has the explicit method's parasitic component (docs/results/behaviour.md, "The period-2 mode"). It is
// measured against the continuous multiplier lambda_s of the Lagrangian with metric M(q), and
// a restart sets p+ = s p~ - (h/2) mu^T lambda_s(q, s p~) with the scale s that keeps the
// energy of the arriving post-momentum p+ - (h/2) f (with the averaged potential), as the
// explicit restart does: since lambda_s = lambda_f + s^2 lambda_b that is a quartic in s.
#include <nonholo/dynamics.hpp>

#include <cmath>
#include <limits>

#include "methods/implicit_internal.hpp"
#include "step/restart_internal.hpp"

namespace nonholo::detail {
namespace {

// x^T M^-1 y with the factorisation in ws.metric_llt (ws.y: scratch).
double inverse_metric_dot(ImplicitWorkspace& ws, ConstVecRef x, ConstVecRef y) {
  ws.y = ws.metric_llt.solve(x);
  return y.dot(ws.y);
}

// Restart of the candidate p+ (ws.p_next) at q, with ws.force = f(t, q); ws.p_tilde,
// velocity, lambda_f and lambda_b hold the candidate's quantities. The energy kept is the
// explicit method's (restart.cpp): that of the arriving post-momentum p_- = p+ - (h/2) f with
// the averaged potential, so that with a constant metric the two forms restart alike.
Status implicit_restart(const Model& model, ImplicitWorkspace& ws, ConstVecRef q, double h) {
  if (!model.momentum_maps().empty())
    return ws.fail(Status::RestartFailed,
                   "the implicit form does not keep momentum maps through a restart: use RestartMode::Never "
                   "(--restart 0) for this model");
  const double half = 0.5 * h;
  auto apply_minv = [&ws](ConstVecRef x, VecRef y) { y = ws.metric_llt.solve(x); };
  ws.mode_c = ws.p_next - half * ws.force;  // p_-
  const double target = arriving_energy(model, q, ws.mode_c, apply_minv, ws.scratch, flat_previous_potential(model, q, h));
  // p_-(s) = a + s p~ + s^2 c: a = -(h/2)(f + mu^T lambda_f), c = -(h/2) mu^T lambda_b.
  ws.mode_a.noalias() = ws.mu.transpose() * ws.lambda_f;
  ws.mode_a = -half * (ws.mode_a + ws.force);
  ws.mode_c.noalias() = ws.mu.transpose() * ws.lambda_b;
  ws.mode_c *= -half;
  double s = 1.0, plain = 0.0;
  if (!scale_keeping_energy(model, q, ws.mode_a, ws.p_tilde, ws.mode_c, target, apply_minv, ws.scratch, ws.y,
                            flat_previous_potential(model, q, h), s,
                            plain)) {
    if (!std::isfinite(plain)) return ws.fail(Status::RestartFailed, NONHOLO_OVERFLOWING_RESTART, target, plain);
    return ws.fail(Status::RestartFailed,
                   "no rescale of p~ keeps the post-momentum energy %.17g (energy change of the plain restart "
                   "%.3g): restart less often or not at all (ImplicitOptions::restart, --restart)",
                   target, plain);
  }
  ws.p_next = ws.mode_a + s * ws.p_tilde + (s * s) * ws.mode_c + half * ws.force;  // p+ = p_- + (h/2) f
  return Status::Ok;
}

}  // namespace

Status continuous_multiplier_parts(const Model& model, ImplicitWorkspace& ws, ConstVecRef q) {
  const int n = model.num_coordinates();
  const Vector& v = ws.velocity;
  // Gamma_i = sum_j (dM/dq_j v)_i v_j - (1/2) v^T dM/dq_i v.
  ws.gamma.setZero();
  for (int j = 0; j < n; ++j) {
    model.metric_derivative(q, j, ws.dmetric);
    ws.scratch.noalias() = ws.dmetric * v;
    ws.gamma += v[j] * ws.scratch;
    ws.gamma[j] -= 0.5 * v.dot(ws.scratch);
  }
  Status status = one_form_bias(model, ws.bias, q, v, ws.lambda_b);
  if (status != Status::Ok) return ws.fail(status, "%s", ws.bias.message());
  ws.y = ws.metric_llt.solve(ws.gamma);
  ws.lambda_b.noalias() -= ws.mu * ws.y;  // bias - mu M^-1 Gamma
  ws.lambda_b = -ws.lambda_b;
  ws.c_llt.solveInPlace(ws.lambda_b);
  ws.y = ws.metric_llt.solve(ws.force);
  ws.lambda_f.noalias() = ws.mu * ws.y;
  ws.lambda_f = -ws.lambda_f;
  ws.c_llt.solveInPlace(ws.lambda_f);
  if (!std::isfinite(ws.lambda_b.sum() + ws.lambda_f.sum()))
    return ws.fail(Status::NonFiniteState,
                   "the continuous multiplier is not finite: check the model's metric, bias and forces, or "
                   "reduce the step size");
  return Status::Ok;
}

Status implicit_control_mode(const Model& model, ImplicitWorkspace& ws, const ImplicitState& s,
                             const ImplicitOptions& o, ModeWatch& watch) {
  ws.parasitic = std::numeric_limits<double>::quiet_NaN();
  ws.restarted = false;
  const RestartOptions& r = o.restart;
  const long now = s.steps + 1;
  const bool measure = measurement_due(r, watch, now);
  bool restart = periodic_restart_due(r, now);
  if (!measure && !restart) return Status::Ok;
  const double h = o.h;
  // p~ = P* p+ and, in ws.lambda, C^-1 mu M^-1 p+ = -(h/2) lambda~.
  Status status = ws.reflect(ws.q_next, ws.p_next, ws.p_tilde, ws.p_minus, o.min_pivot_ratio);
  if (status != Status::Ok) return status;
  ws.velocity = ws.metric_llt.solve(ws.p_tilde);
  if ((status = continuous_multiplier_parts(model, ws, ws.q_next)) != Status::Ok) return status;
  if (measure) {
    // delta = lambda~ - lambda_s; amplitude (h/2) |mu^T delta|_{M^-1} / |p~|_{M^-1}.
    ws.lambda *= -2.0 / h;
    ws.lambda -= ws.lambda_f + ws.lambda_b;
    ws.scratch.noalias() = ws.mu.transpose() * ws.lambda;
    const double mode = inverse_metric_dot(ws, ws.scratch, ws.scratch);
    const double momentum = ws.p_tilde.dot(ws.velocity);
    ws.parasitic = momentum > 0.0 ? 0.5 * h * std::sqrt(mode / momentum)
                                  : (mode > 0.0 ? std::numeric_limits<double>::infinity() : 0.0);
    restart = plan_after_measurement(r, h, watch, now, ws.parasitic) || restart;
  }
  if (restart) {
    if ((status = implicit_restart(model, ws, ws.q_next, h)) != Status::Ok) return status;
    ws.restarted = true;
    plan_after_restart(r, watch, now);
  }
  return Status::Ok;
}

}  // namespace nonholo::detail
