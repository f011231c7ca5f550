// The nonholonomic RATTLE step (DESIGN.md section 2):
//   p_{k+1/2} = p~_k + (h/2)(f_k + mu_k^T lambda~_k)      (state.force holds the bracket)
//   q_{k+1}   = q_k + h M^-1 p_{k+1/2}
//   p^        = p_{k+1/2} + (h/2) f_{k+1}
//   C(q_{k+1}) lambda~_{k+1} = -(2/h) mu_{k+1} M^-1 p^
//   p~_{k+1}  = p^ + (h/2) mu_{k+1}^T lambda~_{k+1}
#include <nonholo/rattle.hpp>

#include <cmath>
#include <sstream>
#include <stdexcept>

namespace nonholo {

void validate(const RattleOptions& options) {
  if (!(options.h > 0.0) || !std::isfinite(options.h)) {
    std::ostringstream os;
    os << "step size h = " << options.h << " must be positive and finite";
    throw std::invalid_argument(os.str());
  }
  if (!(options.min_pivot_ratio >= 0.0) || !(options.min_pivot_ratio < 1.0)) {
    std::ostringstream os;
    os << "min_pivot_ratio = " << options.min_pivot_ratio << " must lie in [0, 1)";
    throw std::invalid_argument(os.str());
  }
}

Status step(const Model& model, Workspace& ws, State& s, const RattleOptions& options) {
  const int n = model.num_coordinates(), m = model.num_one_forms();
  if (&ws.model() != &model)
    return ws.fail(Status::WorkspaceMismatch, "the workspace was built for another model");
  const double h = options.h;
  if (!(h > 0.0) || !std::isfinite(h))
    return ws.fail(Status::InvalidStepSize, "step size h = %g must be positive and finite", h);
  if (s.q.size() != n || s.p.size() != n || s.force.size() != n || s.lambda.size() != m)
    return ws.fail(Status::SizeMismatch,
                   "state sizes q %ld, p %ld, force %ld, lambda %ld; the model needs %d, %d, %d, %d",
                   static_cast<long>(s.q.size()), static_cast<long>(s.p.size()),
                   static_cast<long>(s.force.size()), static_cast<long>(s.lambda.size()), n, n, n, m);
  const double half = 0.5 * h;
  const double t_next = s.t + h;
  const auto& minv = model.inverse_mass();

  // Half kick with the forces at t_k, then drift.
  ws.p_half = s.p + half * s.force;
  minv.multiply(ws.p_half.data(), ws.velocity.data());
  ws.q_next = s.q + h * ws.velocity;

  // Unconstrained half kick with the applied force at t_{k+1}.
  if (model.has_applied_force()) {
    model.applied_force(t_next, ws.q_next, ws.applied, ws.scratch_n);
    ws.p_hat = ws.p_half + half * ws.applied;
    minv.multiply(ws.p_hat.data(), ws.velocity.data());
  } else {
    ws.p_hat = ws.p_half;  // velocity already holds M^-1 p^; applied stays zero
  }

  // Constraint half kick: the multipliers that put p~_{k+1} in the annihilator of D.
  if (m > 0) {
    Status status = ws.evaluate_one_forms(ws.q_next);
    if (status == Status::Ok) status = ws.factorize(options.min_pivot_ratio);
    if (status != Status::Ok) return status;
    model.mu_times(ws.mu_values.data(), ws.velocity.data(), ws.rhs.data());
    ws.rhs *= -2.0 / h;
    if ((status = ws.solve(ws.rhs.data(), ws.lambda.data())) != Status::Ok) return status;
    model.mu_transpose_times(ws.mu_values.data(), ws.lambda.data(), ws.scratch_n.data());
    ws.force_next = ws.applied + ws.scratch_n;
    ws.p_next = ws.p_hat + half * ws.scratch_n;
  } else {
    ws.force_next = ws.applied;
    ws.p_next = ws.p_hat;
  }

  if (!std::isfinite(ws.q_next.sum() + ws.p_next.sum() + ws.force_next.sum()))
    return ws.fail(Status::NonFiniteState, "the step from t = %.17g produced NaN or Inf", s.t);

  s.t = t_next;
  s.q = ws.q_next;
  s.p = ws.p_next;
  s.lambda = ws.lambda;
  s.force = ws.force_next;
  ws.clear_message();
  return Status::Ok;
}

}  // namespace nonholo
