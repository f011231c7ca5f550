// The discrete Lagrange-d'Alembert baseline (dla.hpp): options check, start and step, with the constraints at
// the left point (one solve with C(q_k)) or at the midpoint (simplified Newton).
#include <nonholo/dla.hpp>

#include <cmath>
#include <limits>

#include "base/callback_guard.hpp"
#include "base/option_checks.hpp"

namespace nonholo {

const char* to_string(DlaConstraint c) { return c == DlaConstraint::Midpoint ? "midpoint" : "left"; }

namespace {
detail::OptionProblem dla_problem(const DlaOptions& o) {
  if (auto p = detail::step_size_problem(o.h)) return p;
  if (auto p = detail::newton_problem(o.newton_tolerance, o.max_newton_iterations)) return p;
  return detail::pivot_ratio_problem(o.min_pivot_ratio);
}
}  // namespace

void validate(const DlaOptions& o) { detail::reject_if(dla_problem(o)); }

DlaState dla_start(const State& start, double h) {
  DlaState s;
  s.t = start.t;
  s.q = start.q;
  s.p = start.pre_momentum(h);
  return s;
}

namespace {
Status dla_step_unguarded(const Model& model, Workspace& ws, DlaState& s, const DlaOptions& o) {
  const int n = model.num_coordinates(), m = model.num_one_forms();
  if (&ws.model() != &model)
    return ws.fail(Status::WorkspaceMismatch, "the workspace was built for another model: build one for this model");
  if (model.has_rigid_bodies())
    return ws.fail(Status::MethodNotApplicable,
                   "the DLA baselines are for planar models; this one has 3-D rigid bodies: use the reflection "
                   "method or the reference integrators");
  if (!(o.h > 0.0) || !std::isfinite(o.h))
    return ws.fail(Status::InvalidStepSize, "step size h = %g must be positive and finite", o.h);
  if (s.q.size() != n || s.p.size() != n)
    return ws.fail(Status::SizeMismatch, "state sizes q %ld, p %ld; the model needs %d",
                   static_cast<long>(s.q.size()), static_cast<long>(s.p.size()), n);
  if (model.has_configuration_metric())
    return ws.fail(Status::MethodNotApplicable, "the DLA baseline here needs a constant metric");
  if (o.constraint == DlaConstraint::Midpoint && ws.scratch_nnz.size() != model.num_one_form_values())
    return ws.fail(Status::MethodNotApplicable,
                   "the midpoint DLA step needs a second copy of mu: make the workspace with "
                   "WorkspaceOptions::dla_steps = true");
  const double h = o.h;
  const auto& minv = model.inverse_mass();

  // p_half = p_{k-1/2} + h f_k (the unconstrained kick).
  ws.p_half = s.p;
  if (model.has_applied_force()) {
    model.applied_force(s.t, s.q, ws.applied, ws.scratch_n);
    ws.p_half += h * ws.applied;
  }
  int iterations = 0;
  if (m > 0) {
    Status status = ws.factorize_at(s.q, o.min_pivot_ratio);
    if (status != Status::Ok) return status;
    // Left point: mu_k M^-1 (p_half + h mu_k^T lambda) = 0, one solve. Also the midpoint's
    // first iterate.
    minv.multiply(ws.p_half.data(), ws.velocity.data());
    model.mu_times(ws.mu_values.data(), ws.velocity.data(), ws.rhs.data());
    ws.rhs *= -1.0 / h;
    if ((status = ws.solve(ws.rhs.data(), ws.lambda.data())) != Status::Ok) return status;
    model.mu_transpose_times(ws.mu_values.data(), ws.lambda.data(), ws.scratch_n.data());
    ws.p_half += h * ws.scratch_n;
    if (o.constraint == DlaConstraint::Midpoint) {
      // r = mu(q_mid) M^-1 p_half, corrected with the frozen Jacobian h C(q_k).
      double previous = std::numeric_limits<double>::infinity();
      for (;; ++iterations) {
        minv.multiply(ws.p_half.data(), ws.velocity.data());
        ws.scratch_n2 = s.q + (0.5 * h) * ws.velocity;  // q_mid
        model.one_form_values(ws.scratch_n2, ws.scratch_nnz);
        model.mu_times(ws.scratch_nnz.data(), ws.velocity.data(), ws.rhs.data());
        // Scale of each row: sum_i |mu_ai v_i|.
        const auto& pattern = model.one_form_pattern();
        double worst = 0.0;
        for (int r = 0; r < m; ++r) {
          double scale = 0.0;
          for (int k = pattern.row_ptr[r]; k < pattern.row_ptr[r + 1]; ++k)
            scale += std::abs(ws.scratch_nnz[k] * ws.velocity[pattern.col_idx[k]]);
          const double rel = std::abs(ws.rhs[r]) / (scale > 0.0 ? scale : 1.0);
          worst = std::isnan(rel) ? rel : std::max(worst, rel);
        }
        if (!std::isfinite(worst))
          return ws.fail(Status::NonFiniteState, "midpoint constraint residual is %g: reduce the step size", worst);
        if (worst <= o.newton_tolerance || (worst >= previous && worst <= 1e3 * o.newton_tolerance)) break;
        if (iterations == o.max_newton_iterations)
          return ws.fail(Status::NewtonNotConverged,
                         "midpoint constraints: relative residual %.3g after %d iterations: reduce the step size", worst,
                         iterations);
        previous = worst;
        ws.rhs *= -1.0 / h;
        if ((status = ws.solve(ws.rhs.data(), ws.scratch_m.data())) != Status::Ok) return status;
        model.mu_transpose_times(ws.mu_values.data(), ws.scratch_m.data(), ws.scratch_n.data());
        ws.p_half += h * ws.scratch_n;
      }
    }
  }
  minv.multiply(ws.p_half.data(), ws.velocity.data());
  ws.q_next = s.q + h * ws.velocity;
  if (!std::isfinite(ws.q_next.sum() + ws.p_half.sum()))
    return ws.fail(Status::NonFiniteState, "the step from t = %.17g produced NaN or Inf: reduce the step size (h = %g)", s.t, h);
  s.q.swap(ws.q_next);
  s.p.swap(ws.p_half);
  s.t = s.grid.next(s.t, h);
  s.grid.advance();
  s.newton_iterations = iterations;
  ws.clear_message();
  return Status::Ok;
}

}  // namespace

Status dla_step(const Model& model, Workspace& ws, DlaState& s, const DlaOptions& o) {
  const BusyEntry entry(ws.busy_flag());
  if (!entry.held()) return Status::WorkspaceBusy;
  if (const detail::OptionProblem p = dla_problem(o); p && std::isfinite(o.h) && o.h > 0.0)
    return ws.fail(Status::InvalidOptions, "DlaOptions: %s = %g %s", p.what, p.value, p.rule);
  return detail::guard_callbacks(ws, [&] { return dla_step_unguarded(model, ws, s, o); });
}

}  // namespace nonholo
