#include <nonholo/reference/index_reduced.hpp>

#include <nonholo/dynamics.hpp>

#include <cmath>
#include <limits>
#include <stdexcept>

namespace nonholo::reference {

IndexReducedOde::IndexReducedOde(const Model& model, const WorkspaceOptions& options)
    : model_(&model), ws_(model, options) {
  if (model.has_configuration_metric())
    throw std::invalid_argument("the reference integrators need a constant metric (this model's depends on q)");
  const int n = model.num_coordinates();
  q_.setZero(n);
  v_.setZero(n);
  p_.setZero(n);
  lambda_.setZero(model.num_one_forms());
}

Status IndexReducedOde::rate(double t, const double* y, double* ydot) {
  const int n = model_->num_coordinates();
  q_ = Eigen::Map<const Vector>(y, n);
  v_ = Eigen::Map<const Vector>(y + n, n);
  // lambda; constraint_multiplier leaves f(t, q) in ws.applied when there is a force.
  const Status status = constraint_multiplier(*model_, ws_, t, q_, v_, lambda_, 0.0);
  if (status != Status::Ok) return status;
  if (model_->num_one_forms() > 0)
    model_->mu_transpose_times(ws_.mu_values.data(), lambda_.data(), p_.data());
  else
    p_.setZero();
  if (model_->has_applied_force()) {
    if (model_->num_one_forms() == 0) model_->applied_force(t, q_, ws_.applied, ws_.scratch_n);
    p_ += ws_.applied;
  }
  for (int i = 0; i < n; ++i) ydot[i] = y[n + i];
  model_->inverse_mass().multiply(p_.data(), ydot + n);
  return Status::Ok;
}

Status IndexReducedOde::project(double* y) {
  const int n = model_->num_coordinates(), m = model_->num_one_forms();
  Eigen::Map<Vector> q(y, n), v(y + n, n);
  if (model_->num_holonomic() > 0) {
    const auto& rows = model_->holonomic_rows();
    const double tolerance =
        std::max(1e-13, 16.0 * std::numeric_limits<double>::epsilon() * q.lpNorm<Eigen::Infinity>());
    for (int it = 0; it < 10; ++it) {
      model_->gap(q, ws_.gap);
      if (!(ws_.gap.lpNorm<Eigen::Infinity>() > tolerance)) break;
      Status status = ws_.factorize_at(q, 0.0);
      if (status != Status::Ok) return status;
      ws_.rhs.setZero();
      for (int j = 0; j < model_->num_holonomic(); ++j) ws_.rhs[rows[j]] = ws_.gap[j];
      if ((status = ws_.solve(ws_.rhs.data(), lambda_.data())) != Status::Ok) return status;
      model_->mu_transpose_times(ws_.mu_values.data(), lambda_.data(), p_.data());
      model_->inverse_mass().multiply(p_.data(), ws_.scratch_n.data());
      q -= ws_.scratch_n;  // mu(q) of the move is [g; 0]: Newton on g, the other rows untouched
    }
  }
  if (m == 0) return Status::Ok;
  model_->mass().multiply(v.data(), p_.data());
  const Status status = project_momentum(*model_, ws_, q, p_, p_, 0.0);
  if (status != Status::Ok) return status;
  model_->inverse_mass().multiply(p_.data(), v.data());
  return Status::Ok;
}

double IndexReducedOde::energy(const double* y) {
  const int n = model_->num_coordinates();
  const Eigen::Map<const Vector> q(y, n), v(y + n, n);
  model_->mass().multiply(v.data(), p_.data());
  return 0.5 * v.dot(p_) + model_->potential(q);
}

double IndexReducedOde::residual(const double* y) {
  const int n = model_->num_coordinates();
  if (model_->num_one_forms() == 0) return 0.0;
  const Eigen::Map<const Vector> q(y, n);
  ws_.evaluate_one_forms(q);
  model_->mu_times(ws_.mu_values.data(), y + n, ws_.scratch_m.data());
  return std::isfinite(ws_.scratch_m.sum()) ? ws_.scratch_m.lpNorm<Eigen::Infinity>()
                                            : std::numeric_limits<double>::quiet_NaN();
}

double IndexReducedOde::gap(const double* y) {
  if (model_->num_holonomic() == 0) return 0.0;
  const Eigen::Map<const Vector> q(y, model_->num_coordinates());
  model_->gap(q, ws_.gap);
  return ws_.gap.lpNorm<Eigen::Infinity>();
}

}  // namespace nonholo::reference
