// The implicit general form for a metric M(q) (implicit.hpp): its workspace, the M(q)-orthogonal reflection,
// the consistent start and the step (quasi-Newton on the midpoint discrete Lagrangian).
#include <nonholo/implicit.hpp>

#include <nonholo/dynamics.hpp>
#include <nonholo/workspace.hpp>

#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>

#include "base/callback_guard.hpp"
#include "base/option_checks.hpp"
#include "methods/implicit_internal.hpp"

namespace nonholo {

namespace {
detail::OptionProblem implicit_problem(const ImplicitOptions& o) {
  if (auto p = detail::step_size_problem(o.h)) return p;
  if (auto p = detail::newton_problem(o.newton_tolerance, o.max_newton_iterations)) return p;
  if (auto p = detail::pivot_ratio_problem(o.min_pivot_ratio)) return p;
  return detail::restart_problem(o.restart);
}
}  // namespace

void validate(const ImplicitOptions& o) { detail::reject_if(implicit_problem(o)); }

ImplicitWorkspace::ImplicitWorkspace(const Model& model)
    : metric(Eigen::MatrixXd::Zero(model.num_coordinates(), model.num_coordinates())),
      dmetric(metric), jacobian(metric),
      mu(Eigen::MatrixXd::Zero(model.num_one_forms(), model.num_coordinates())),
      w(Eigen::MatrixXd::Zero(model.num_coordinates(), model.num_one_forms())),
      c(Eigen::MatrixXd::Zero(model.num_one_forms(), model.num_one_forms())),
      metric_llt(model.num_coordinates()), c_llt(model.num_one_forms()),
      jacobian_lu(model.num_coordinates()), bias(model), model_(&model) {
  if (!model.has_configuration_metric())
    throw std::invalid_argument("the implicit general form needs a model with a configuration metric "
                                "(ModelBuilder::configuration_metric); use step() for a constant metric");
  const int n = model.num_coordinates(), m = model.num_one_forms();
  for (Vector* v : {&delta, &residual, &rhs, &terms, &q_mid, &q_next, &p_minus, &p_next, &force, &scratch, &y,
                    &p_tilde, &velocity, &gamma, &mode_a, &mode_c})
    v->setZero(n);
  mu_values.setZero(model.num_one_form_values());
  for (Vector* v : {&lambda, &lambda_f, &lambda_b}) v->setZero(m);
}

Status ImplicitWorkspace::fail(Status status, const char* format, ...) {
  va_list args;
  va_start(args, format);
  message_.vset(format, args);
  va_end(args);
  return status;
}

namespace detail {

void dense_one_forms(const Model& model, ConstVecRef q, ImplicitWorkspace& ws) {
  if (model.num_one_forms() == 0) return;
  model.one_form_values(q, ws.mu_values);
  const auto& pat = model.one_form_pattern();
  ws.mu.setZero();
  for (int r = 0; r < pat.rows; ++r)
    for (int k = pat.row_ptr[r]; k < pat.row_ptr[r + 1]; ++k) ws.mu(r, pat.col_idx[k]) = ws.mu_values[k];
}

void applied(const Model& model, double t, ConstVecRef q, ImplicitWorkspace& ws) {
  if (model.has_applied_force())
    model.applied_force(t, q, ws.force, ws.scratch);
  else
    ws.force.setZero();
}

}  // namespace detail

namespace {

using detail::applied;
using detail::dense_one_forms;

// terms_i = delta^T dM/dq_i (q_mid) delta.
void metric_terms(const Model& model, ImplicitWorkspace& ws) {
  const int n = model.num_coordinates();
  for (int i = 0; i < n; ++i) {
    model.metric_derivative(ws.q_mid, i, ws.dmetric);
    ws.scratch.noalias() = ws.dmetric * ws.delta;
    ws.terms[i] = ws.delta.dot(ws.scratch);
  }
}

}  // namespace

Status ImplicitWorkspace::reflect(ConstVecRef q, ConstVecRef p_plus, VecRef average, VecRef reflected,
                                  double min_pivot_ratio) {
  const Model& model = *model_;
  model.metric(q, metric);
  metric_llt.compute(metric);
  if (metric_llt.info() != Eigen::Success) return fail(Status::NonFiniteState, "the metric is not positive definite here: check the model's metric, or reduce the step size");
  if (model.num_one_forms() == 0) {
    average = p_plus;
    reflected = p_plus;
    return Status::Ok;
  }
  dense_one_forms(model, q, *this);
  w = metric_llt.solve(mu.transpose());  // M^-1 mu^T
  c.noalias() = mu * w;
  c_llt.compute(c);
  // Pivot test as in the sparse layer: L_jj^2 / C_jj.
  const auto& l = c_llt.matrixLLT();
  for (int j = 0; j < c.rows(); ++j) {
    const double ratio = l(j, j) * l(j, j) / c(j, j);
    if (!(ratio > min_pivot_ratio) || c_llt.info() != Eigen::Success)
      return fail(Status::NearlyDependentOneForms, "pivot of row %d of C is %.3g times its diagonal: nearly dependent one-forms; reduce the step size or lower min_pivot_ratio",
                  j, ratio);
  }
  rhs.noalias() = metric_llt.solve(p_plus);  // M^-1 p+
  lambda.noalias() = mu * rhs;
  c_llt.solveInPlace(lambda);
  scratch.noalias() = mu.transpose() * lambda;  // Q* p+
  average = p_plus - scratch;
  reflected = p_plus - 2.0 * scratch;
  return Status::Ok;
}

double ImplicitWorkspace::kinetic_energy(ConstVecRef q, ConstVecRef p) {
  model_->metric(q, metric);
  metric_llt.compute(metric);
  scratch = metric_llt.solve(p);
  return 0.5 * p.dot(scratch);
}

ImplicitState implicit_start(const Model& model, ImplicitWorkspace& ws, double t0, ConstVecRef q0,
                             ConstVecRef v_guess, const ImplicitOptions& o) {
  const BusyEntry entry(ws.busy_flag());
  require_held(entry, "implicit_start");
  validate(o);
  const int n = model.num_coordinates(), m = model.num_one_forms();
  if (q0.size() != n || v_guess.size() != n) {
    std::ostringstream os;
    os << "implicit start: expected " << n << " coordinates and velocities, got " << q0.size() << " and "
       << v_guess.size();
    throw std::invalid_argument(os.str());
  }
  ImplicitState s;
  s.t = t0;
  s.q = q0;
  model.metric(q0, ws.metric);
  Vector p = ws.metric * v_guess, p_tilde(n), unused(n);
  if (ws.reflect(q0, p, p_tilde, unused, o.min_pivot_ratio) != Status::Ok)
    throw std::invalid_argument(std::string("implicit start: ") + ws.message());
  // lambda(0) of the continuous equations, with the metric's Christoffel terms.
  ws.velocity = ws.metric_llt.solve(p_tilde);
  applied(model, t0, q0, ws);
  Vector constraint_force = Vector::Zero(n);
  if (m > 0) {
    if (detail::continuous_multiplier_parts(model, ws, q0) != Status::Ok)
      throw std::invalid_argument(std::string("implicit start: ") + ws.message());
    constraint_force = ws.mu.transpose() * (ws.lambda_f + ws.lambda_b);
  }
  s.p = p_tilde - (0.5 * o.h) * constraint_force;  // p+ = p~ - (h/2) mu^T lambda (it holds (h/2) f already)
  return s;
}

namespace {
Status implicit_step_unguarded(const Model& model, ImplicitWorkspace& ws, ImplicitState& s, const ImplicitOptions& o) {
  const int n = model.num_coordinates();
  if (&ws.model() != &model) return ws.fail(Status::WorkspaceMismatch, "the workspace was built for another model: build one for this model");
  if (!(o.h > 0.0) || !std::isfinite(o.h))
    return ws.fail(Status::InvalidStepSize, "step size h = %g must be positive and finite", o.h);
  if (s.q.size() != n || s.p.size() != n)
    return ws.fail(Status::SizeMismatch, "state sizes q %ld, p %ld; the model needs %d",
                   static_cast<long>(s.q.size()), static_cast<long>(s.p.size()), n);
  const double h = o.h;
  Status status = ws.reflect(s.q, s.p, ws.y, ws.p_minus, o.min_pivot_ratio);
  if (status != Status::Ok) return status;
  // Solve (1/h) M(q_mid) delta - (1/4h) terms(delta) = p- + (h/2) f_k for delta = q_{k+1} - q_k.
  applied(model, s.t, s.q, ws);
  ws.rhs = ws.p_minus + (0.5 * h) * ws.force;
  ws.delta = ws.metric_llt.solve(ws.rhs);  // predictor with M(q_k)
  ws.delta *= h;
  double previous = std::numeric_limits<double>::infinity();
  int it = 0;
  for (;; ++it) {
    ws.q_mid = s.q + 0.5 * ws.delta;
    model.metric(ws.q_mid, ws.metric);
    metric_terms(model, ws);
    ws.residual.noalias() = ws.metric * ws.delta;  // no temporaries: a step never allocates
    ws.residual /= h;
    const double scale = ws.residual.lpNorm<Eigen::Infinity>() + ws.rhs.lpNorm<Eigen::Infinity>();
    ws.residual -= ws.terms / (4.0 * h) + ws.rhs;
    const double worst = ws.residual.lpNorm<Eigen::Infinity>() / (scale > 0.0 ? scale : 1.0);
    if (!std::isfinite(worst)) return ws.fail(Status::NonFiniteState, "Newton residual is %g: reduce the step size", worst);
    if (worst <= o.newton_tolerance || (worst >= previous && worst <= 1e3 * o.newton_tolerance)) break;
    if (it == o.max_newton_iterations)
      return ws.fail(Status::NewtonNotConverged, "implicit step: relative residual %.3g after %d Newton iterations: reduce the step size",
                     worst, it);
    previous = worst;
    // J = (1/h)[M + (1/2) sum_l dM/dq_j(:, l) delta_l (column j) - (1/2) (dM/dq_i delta)^T (row i)],
    // the second derivatives of M dropped (a quasi-Newton step, O(h^2) from exact).
    ws.jacobian = ws.metric;
    for (int j = 0; j < n; ++j) {
      model.metric_derivative(ws.q_mid, j, ws.dmetric);
      ws.scratch.noalias() = ws.dmetric * ws.delta;
      ws.jacobian.col(j) += 0.5 * ws.scratch;     // d/d delta_j of M(q_mid) delta
      ws.jacobian.row(j) -= 0.5 * ws.scratch.transpose();  // d/d delta of the j-th term / 4
    }
    ws.jacobian /= h;
    ws.jacobian_lu.compute(ws.jacobian);
    ws.scratch = ws.jacobian_lu.solve(ws.residual);
    ws.delta -= ws.scratch;
  }
  // p+_{k+1} = D2 Ld(q_k, q_{k+1}) + (h/2) F_{k+1} = (1/h) M delta + (1/4h) terms + (h/2) f_{k+1}.
  ws.q_next = s.q + ws.delta;
  ws.p_next.noalias() = ws.metric * ws.delta;
  ws.p_next /= h;
  ws.p_next += ws.terms / (4.0 * h);
  applied(model, s.t + h, ws.q_next, ws);
  ws.p_next += (0.5 * h) * ws.force;
  if (!std::isfinite(ws.q_next.sum() + ws.p_next.sum()))
    return ws.fail(Status::NonFiniteState, "the step from t = %.17g produced NaN or Inf: reduce the step size (h = %g)", s.t, o.h);
  ModeWatch watch = s.watch;
  ws.parasitic = 0.0;
  ws.restarted = false;
  if (model.num_one_forms() > 0 && (status = detail::implicit_control_mode(model, ws, s, o, watch)) != Status::Ok)
    return status;
  s.q.swap(ws.q_next);
  s.p.swap(ws.p_next);
  s.t = s.grid.next(s.t, h);
  s.grid.advance();
  s.newton_iterations = it;
  ++s.steps;
  if (ws.restarted) ++s.restarts;
  s.watch = watch;
  return Status::Ok;
}

}  // namespace

Status implicit_step(const Model& model, ImplicitWorkspace& ws, ImplicitState& s, const ImplicitOptions& o) {
  const BusyEntry entry(ws.busy_flag());
  if (!entry.held()) return Status::WorkspaceBusy;
  if (const detail::OptionProblem p = implicit_problem(o); p && std::isfinite(o.h) && o.h > 0.0)
    return ws.fail(Status::InvalidOptions, "ImplicitOptions: %s = %g %s", p.what, p.value, p.rule);
  return detail::guard_callbacks(ws, [&] { return implicit_step_unguarded(model, ws, s, o); });
}

}  // namespace nonholo
