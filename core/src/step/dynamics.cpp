// The continuous-time quantities (dynamics.hpp): the bias mu' qdot (from a chain's cached sin/cos, the model,
// or central differences), the M-orthogonal projection and the multiplier of the index-reduced equations.
#include <nonholo/dynamics.hpp>

#include <cmath>
#include <limits>

#include "step/chain/chain_sweep.hpp"
#include "step/dynamics_internal.hpp"
#include "step/rigid/drift.hpp"

namespace nonholo {
namespace detail {

Status one_form_bias(const Model& model, Workspace& ws, ConstVecRef q, ConstVecRef qdot, VecRef bias) {
  const int m = model.num_one_forms();
  if (m == 0) return Status::Ok;
  if (ws.sincos_hold(q)) {  // a fused chain step left sin/cos of q: no trigonometry again
    detail::chain_bias_from_sincos(model, ws, qdot, bias);
    return Status::Ok;
  }
  if (model.has_analytic_bias()) {
    model.analytic_bias(q, qdot, bias);
    return Status::Ok;
  }
  const double speed = qdot.lpNorm<Eigen::Infinity>();
  if (speed == 0.0) {
    bias.setZero();
    return Status::Ok;
  }
  // Central difference along qdot; the displacement's size balances truncation (delta^2)
  // against cancellation (eps / delta).
  const double delta = std::cbrt(std::numeric_limits<double>::epsilon()) *
                       (1.0 + q.lpNorm<Eigen::Infinity>()) / speed;
  const int nnz = model.num_one_form_values();
  Vector& mu_plus = ws.scratch_nnz;
  Vector& mu_minus = ws.scratch_nnz2;
  if (model.has_rigid_bodies()) {  // along q exp(+-delta hat(Omega)): the motion's own curve
    ws.scratch_n2 = delta * qdot;
    model.retract(q, ws.scratch_n2, ws.scratch_q);
    model.one_form_values(ws.scratch_q, mu_plus);
    ws.scratch_n2 = -delta * qdot;
    model.retract(q, ws.scratch_n2, ws.scratch_q);
    model.one_form_values(ws.scratch_q, mu_minus);
  } else {
    ws.scratch_n2 = q + delta * qdot;
    model.one_form_values(ws.scratch_n2, mu_plus);
    ws.scratch_n2 = q - delta * qdot;
    model.one_form_values(ws.scratch_n2, mu_minus);
  }
  for (int k = 0; k < nnz; ++k) mu_plus[k] = (mu_plus[k] - mu_minus[k]) / (2.0 * delta);
  model.mu_times(mu_plus.data(), qdot.data(), bias.data());
  if (!std::isfinite(bias.sum()))
    return ws.fail(Status::NonFiniteOneForms, "the difference quotient of mu along qdot is not finite: check the one-form values near q, or give the model its bias (one_form_bias)");
  return Status::Ok;
}

Status constraint_bias(const Model& model, Workspace& ws, ConstVecRef q, ConstVecRef qdot, VecRef bias) {
  const Status status = detail::one_form_bias(model, ws, q, qdot, bias);
  if (status != Status::Ok || !model.has_rigid_bodies() || model.num_one_forms() == 0) return status;
  // + mu M^-1 g(v); mu(q) is in the workspace (the callers evaluated it at q).
  gyroscopic_acceleration(model, qdot, ws.gyroscopic);
  model.mu_times(ws.mu_values.data(), ws.gyroscopic.data(), ws.gyroscopic_m.data());
  bias += ws.gyroscopic_m;
  return Status::Ok;
}

Status project_momentum(const Model& model, Workspace& ws, ConstVecRef q, ConstVecRef p,
                        VecRef p_out, double min_pivot_ratio) {
  if (model.num_one_forms() == 0) {
    p_out = p;
    return Status::Ok;
  }
  Status status = ws.factorize_at(q, min_pivot_ratio);
  if (status != Status::Ok) return status;
  model.inverse_mass().multiply(p.data(), ws.velocity.data());
  model.mu_times(ws.mu_values.data(), ws.velocity.data(), ws.rhs.data());
  if ((status = ws.solve(ws.rhs.data(), ws.scratch_m.data())) != Status::Ok) return status;
  model.mu_transpose_times(ws.mu_values.data(), ws.scratch_m.data(), ws.scratch_n.data());
  p_out = p - ws.scratch_n;
  return Status::Ok;
}

Status constraint_multiplier(const Model& model, Workspace& ws, double t, ConstVecRef q,
                             ConstVecRef qdot, VecRef lambda, double min_pivot_ratio) {
  if (model.num_one_forms() == 0) return Status::Ok;
  Status status = ws.factorize_at(q, min_pivot_ratio);
  if (status == Status::Ok) status = detail::constraint_bias(model, ws, q, qdot, ws.rhs);
  if (status != Status::Ok) return status;
  if (model.has_applied_force()) {
    model.applied_force(t, q, ws.applied, ws.scratch_n);
    model.inverse_mass().multiply(ws.applied.data(), ws.velocity.data());
    model.mu_times(ws.mu_values.data(), ws.velocity.data(), ws.scratch_m.data());
    ws.rhs += ws.scratch_m;
  }
  ws.rhs = -ws.rhs;
  return ws.solve(ws.rhs.data(), lambda.data());
}

}  // namespace detail

// The public forms take the workspace for the call.
Status one_form_bias(const Model& model, Workspace& ws, ConstVecRef q, ConstVecRef qdot, VecRef bias) {
  return with_flag(ws.busy_flag(), [&] { return detail::one_form_bias(model, ws, q, qdot, bias); });
}

Status constraint_bias(const Model& model, Workspace& ws, ConstVecRef q, ConstVecRef qdot, VecRef bias) {
  return with_flag(ws.busy_flag(), [&] { return detail::constraint_bias(model, ws, q, qdot, bias); });
}

Status project_momentum(const Model& model, Workspace& ws, ConstVecRef q, ConstVecRef p, VecRef p_out,
                        double min_pivot_ratio) {
  return with_flag(ws.busy_flag(), [&] { return detail::project_momentum(model, ws, q, p, p_out, min_pivot_ratio); });
}

Status constraint_multiplier(const Model& model, Workspace& ws, double t, ConstVecRef q, ConstVecRef qdot,
                             VecRef lambda, double min_pivot_ratio) {
  return with_flag(ws.busy_flag(), [&] { return detail::constraint_multiplier(model, ws, t, q, qdot, lambda, min_pivot_ratio); });
}

}  // namespace nonholo
