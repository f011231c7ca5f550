// The dense, independent re-implementation of the scheme (dense_reference.hpp).
#include "support/dense_reference.hpp"

namespace nonholo::testing {

Eigen::MatrixXd dense_mass(const Model& model) {
  const int n = model.num_coordinates();
  Eigen::MatrixXd m = Eigen::MatrixXd::Zero(n, n);
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) m(i, j) = model.mass().entry(i, j);
  return m;
}

Eigen::MatrixXd dense_one_forms(const Model& model, ConstVecRef q) {
  const auto& pat = model.one_form_pattern();
  Vector values(pat.nnz());
  model.one_form_values(q, values);
  Eigen::MatrixXd mu = Eigen::MatrixXd::Zero(pat.rows, pat.cols);
  for (int r = 0; r < pat.rows; ++r)
    for (int k = pat.row_ptr[r]; k < pat.row_ptr[r + 1]; ++k) mu(r, pat.col_idx[k]) = values[k];
  return mu;
}

Vector dense_applied_force(const Model& model, double t, ConstVecRef q) {
  Vector f = Vector::Zero(model.num_coordinates()), scratch(model.num_coordinates());
  if (model.has_applied_force()) model.applied_force(t, q, f, scratch);
  return f;
}

Vector dense_project(const Model& model, ConstVecRef q, ConstVecRef p) {
  const Eigen::MatrixXd minv = dense_mass(model).inverse();
  const Eigen::MatrixXd mu = dense_one_forms(model, q);
  const Eigen::MatrixXd c = mu * minv * mu.transpose();
  return p - mu.transpose() * c.fullPivLu().solve(mu * minv * p);
}

Vector dense_multiplier(const Model& model, double t, ConstVecRef q, ConstVecRef qdot) {
  const Eigen::MatrixXd minv = dense_mass(model).inverse();
  const Eigen::MatrixXd mu = dense_one_forms(model, q);
  Vector bias(model.num_one_forms());
  model.analytic_bias(q, qdot, bias);
  const Eigen::MatrixXd c = mu * minv * mu.transpose();
  return c.fullPivLu().solve(-bias - mu * minv * dense_applied_force(model, t, q));
}

Eigen::MatrixXd dense_reflection(const Model& model, ConstVecRef q) {
  const int n = model.num_coordinates();
  const Eigen::MatrixXd minv = dense_mass(model).inverse();
  const Eigen::MatrixXd mu = dense_one_forms(model, q);
  const Eigen::MatrixXd c = mu * minv * mu.transpose();
  const Eigen::MatrixXd q_star = mu.transpose() * c.fullPivLu().solve(mu * minv);
  return Eigen::MatrixXd::Identity(n, n) - 2.0 * q_star;
}

void dense_rattle_step(const Model& model, State& s, double h) {
  const Eigen::MatrixXd minv = dense_mass(model).inverse();
  const Vector p_half = s.p + 0.5 * h * s.force;
  const Vector q_next = s.q + h * minv * p_half;
  const Vector f_next = dense_applied_force(model, s.t + h, q_next);
  const Vector p_hat = p_half + 0.5 * h * f_next;
  const Eigen::MatrixXd mu = dense_one_forms(model, q_next);
  const Eigen::MatrixXd c = mu * minv * mu.transpose();
  const Vector lambda = c.fullPivLu().solve(-(2.0 / h) * mu * minv * p_hat);
  s.t += h;
  s.q = q_next;
  s.p = p_hat + 0.5 * h * mu.transpose() * lambda;
  s.lambda = lambda;
  s.force = f_next + mu.transpose() * lambda;
}

}  // namespace nonholo::testing
