// The explicit step's stability limit (stability.hpp): power iteration in the M inner product for the
// stiffest frequency of the constrained motion, and the largest stable h of a plain or composed step.
#include <nonholo/stability.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace nonholo {
namespace {

// x <- P x = x - M^-1 mu^T C^-1 mu x (C(q) factorised in ws).
void project(const Model& model, Workspace& ws, Vector& x, Vector& scratch) {
  if (model.num_one_forms() == 0) return;
  model.mu_times(ws.mu_values.data(), x.data(), ws.rhs.data());
  if (ws.solve(ws.rhs.data(), ws.scratch_m.data()) != Status::Ok)
    throw std::invalid_argument(std::string("stiffest_frequency: ") + ws.message());
  model.mu_transpose_times(ws.mu_values.data(), ws.scratch_m.data(), scratch.data());
  model.inverse_mass().multiply(scratch.data(), ws.scratch_n.data());
  x -= ws.scratch_n;
}

double m_norm(const Model& model, const Vector& x, Vector& scratch) {
  model.mass().multiply(x.data(), scratch.data());
  return std::sqrt(std::max(0.0, x.dot(scratch)));
}

}  // namespace

StiffnessEstimate stiffest_frequency(const Model& model, Workspace& ws, double t, ConstVecRef q,
                                     const StiffnessEstimate* previous, int max_iterations, double tolerance,
                                     double min_pivot_ratio) {
  StiffnessEstimate e;
  if (!model.has_applied_force()) return e;
  const BusyEntry entry(ws.busy_flag());
  require_held(entry, "stiffest_frequency");
  const int n = model.num_velocities();
  if (model.num_one_forms() > 0 && ws.factorize_at(q, min_pivot_ratio) != Status::Ok)
    throw std::invalid_argument(std::string("stiffest_frequency: ") + ws.message());
  Vector x(n), y(n), qe(model.num_configuration()), f_plus(n), f_minus(n), scratch(n), scratch2(n);
  if (previous && previous->direction.size() == n) {
    x = previous->direction;
  } else {  // a fixed start with a component along every direction (no randomness: reproducible)
    for (int i = 0; i < n; ++i) x[i] = 1.0 + 0.5 * std::sin(1.7 * i + 0.3);
  }
  project(model, ws, x, scratch);
  double norm = m_norm(model, x, scratch);
  if (!(norm > 0.0)) return e;
  x /= norm;
  // Central differences of f along x, relative step: exact for linear forces up to round-off.
  const double scale = std::max(1.0, q.lpNorm<Eigen::Infinity>());
  double ratio = 0.0;
  for (int it = 1; it <= max_iterations; ++it) {
    const double eps = 1e-6 * scale / std::max(x.lpNorm<Eigen::Infinity>(), 1e-300);
    if (model.has_rigid_bodies()) {  // q moved along +-eps x (a velocity-space direction)
      scratch2 = eps * x;
      model.retract(q, scratch2, qe);
      model.applied_force(t, qe, f_plus, scratch);
      scratch2 = -eps * x;
      model.retract(q, scratch2, qe);
      model.applied_force(t, qe, f_minus, scratch);
    } else {
      qe = q + eps * x;
      model.applied_force(t, qe, f_plus, scratch);
      qe = q - eps * x;
      model.applied_force(t, qe, f_minus, scratch);
    }
    // y = M^-1 K x with K x = -(f(q + eps x) - f(q - eps x)) / (2 eps), then projected.
    scratch2 = (f_minus - f_plus) / (2.0 * eps);
    model.inverse_mass().multiply(scratch2.data(), y.data());
    project(model, ws, y, scratch);
    const double next = m_norm(model, y, scratch);  // |A x|_M with |x|_M = 1
    e.iterations = it;
    if (!std::isfinite(next)) {
      e.omega = std::numeric_limits<double>::infinity();
      return e;
    }
    const bool settled = std::abs(next - ratio) <= tolerance * next;
    ratio = std::max(ratio, next);
    if (!(next > 0.0)) break;  // the forces do not vary along D(q): no oscillation
    x = y / next;
    if (settled) {
      e.converged = true;
      break;
    }
  }
  e.omega = std::sqrt(ratio);
  e.direction = x;
  return e;
}

double stability_limit(double omega, int order, Composition composition) {
  if (!(omega > 0.0)) return std::numeric_limits<double>::infinity();
  if (order == 2) return 2.0 / omega;
  const CompositionScheme scheme = composition_scheme(order, composition);
  double widest = 0.0;  // the largest plain step, |c_i| H, must stay below 2 / omega
  for (int i = 0; i < scheme.steps; ++i) widest = std::max(widest, std::abs(scheme.c[i]));
  return 2.0 / (omega * widest);
}

}  // namespace nonholo
