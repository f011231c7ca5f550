// The index-reduced equations of a Model (index_reduced.hpp): the right-hand side with lambda, the projection
// onto the constraints, and the energy, residual and gap of a state y.
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
  const int n = model.num_velocities();
  q_.setZero(model.num_configuration());
  v_.setZero(n);
  p_.setZero(n);
  if (model.has_rigid_bodies()) gyro_.setZero(n);
  lambda_.setZero(model.num_one_forms());
}

Status IndexReducedOde::rate(double t, const double* y, double* ydot) {
  const int n = model_->num_velocities(), nq = model_->num_configuration();
  q_ = Eigen::Map<const Vector>(y, nq);
  v_ = Eigen::Map<const Vector>(y + nq, n);
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
  if (!model_->has_rigid_bodies()) {
    for (int i = 0; i < n; ++i) ydot[i] = y[n + i];
    model_->inverse_mass().multiply(p_.data(), ydot + n);
    return Status::Ok;
  }
  model_->inverse_mass().multiply(p_.data(), ydot + nq);
  gyroscopic_acceleration(*model_, v_, gyro_);
  for (int i = 0; i < n; ++i) ydot[nq + i] += gyro_[i];
  for (int b = 0; b < model_->num_bodies(); ++b) {  // qdot from v, body by body
    const Body& body = model_->body(b);
    if (body.kind != BodyKind::Rigid) {
      for (int i = 0; i < body.size; ++i) ydot[body.q_offset + i] = v_[body.offset + i];
      continue;
    }
    const double* r = y + body.q_offset;  // (w, x, y, z); qdot = r (x) (0, Omega) / 2
    const double wx = 0.5 * v_[body.offset], wy = 0.5 * v_[body.offset + 1], wz = 0.5 * v_[body.offset + 2];
    double* d = ydot + body.q_offset;
    d[0] = -r[1] * wx - r[2] * wy - r[3] * wz;
    d[1] = r[0] * wx + r[2] * wz - r[3] * wy;
    d[2] = r[0] * wy - r[1] * wz + r[3] * wx;
    d[3] = r[0] * wz + r[1] * wy - r[2] * wx;
    for (int i = 0; i < body.translation; ++i) d[4 + i] = v_[body.offset + 3 + i];
  }
  return Status::Ok;
}

Status IndexReducedOde::project(double* y) {
  const int n = model_->num_velocities(), nq = model_->num_configuration(), m = model_->num_one_forms();
  Eigen::Map<Vector> q(y, nq), v(y + nq, n);
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
      if (model_->has_rigid_bodies()) {  // along -M^-1 mu^T lambda on the group
        ws_.scratch_n = -ws_.scratch_n;
        model_->retract(q, ws_.scratch_n, q);
      } else {
        q -= ws_.scratch_n;  // mu(q) of the move is [g; 0]: Newton on g, the other rows untouched
      }
    }
  }
  for (const RigidBlock& r : model_->rigid_bodies()) q.segment<4>(r.q).normalize();
  if (m == 0) return Status::Ok;
  model_->mass().multiply(v.data(), p_.data());
  const Status status = project_momentum(*model_, ws_, q, p_, p_, 0.0);
  if (status != Status::Ok) return status;
  model_->inverse_mass().multiply(p_.data(), v.data());
  return Status::Ok;
}

double IndexReducedOde::energy(const double* y) {
  const int n = model_->num_velocities(), nq = model_->num_configuration();
  const Eigen::Map<const Vector> q(y, nq), v(y + nq, n);
  model_->mass().multiply(v.data(), p_.data());
  return 0.5 * v.dot(p_) + model_->potential(q);
}

double IndexReducedOde::residual(const double* y) {
  const int nq = model_->num_configuration();
  if (model_->num_one_forms() == 0) return 0.0;
  const Eigen::Map<const Vector> q(y, nq);
  ws_.evaluate_one_forms(q);
  model_->mu_times(ws_.mu_values.data(), y + nq, ws_.scratch_m.data());
  return std::isfinite(ws_.scratch_m.sum()) ? ws_.scratch_m.lpNorm<Eigen::Infinity>()
                                            : std::numeric_limits<double>::quiet_NaN();
}

double IndexReducedOde::gap(const double* y) {
  if (model_->num_holonomic() == 0) return 0.0;
  const Eigen::Map<const Vector> q(y, model_->num_configuration());
  model_->gap(q, ws_.gap);
  return ws_.gap.lpNorm<Eigen::Infinity>();
}

}  // namespace nonholo::reference
