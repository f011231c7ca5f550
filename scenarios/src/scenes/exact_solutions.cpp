// The closed-form oracles (exact_solutions.hpp): the Chaplygin sleigh (its path by Gauss-Legendre panels),
// the nonholonomic particle and the Suslov problem (its orientation by fine RK4 steps).
#include <nonholo/scenarios/exact_solutions.hpp>

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace nonholo::scenarios {
namespace {

// 8-point Gauss-Legendre nodes and weights on [-1, 1].
constexpr double kNodes[8] = {-0.9602898564975363, -0.7966664774136267, -0.5255324099163290,
                              -0.1834346424956498, 0.1834346424956498,  0.5255324099163290,
                              0.7966664774136267,  0.9602898564975363};
constexpr double kWeights[8] = {0.1012285362903763, 0.2223810344533745, 0.3137066458778873,
                                0.3626837833783620, 0.3626837833783620, 0.3137066458778873,
                                0.2223810344533745, 0.1012285362903763};
// Panels no longer than this keep the 16th-order rule's error at round-off for the
// sleigh's smooth, O(1)-time-scale integrand.
constexpr double kPanel = 0.05;

}  // namespace

SleighExact::SleighExact(double m, double I, double a, double v0, double omega0, double x0,
                         double y0, double theta0)
    : m_(m), a_(a), v0_(v0), w0_(omega0), x0_(x0), y0_(y0), th0_(theta0) {
  const double J = I + m * a * a;
  straight_ = omega0 == 0.0 || a == 0.0;
  if (straight_) return;
  c_ = std::sqrt(v0 * v0 + (J / m) * omega0 * omega0);
  kappa_ = a * m * c_ / J;
  phi_ = std::atanh(v0 / c_);
}

double SleighExact::speed(double t) const {
  return straight_ ? v0_ : c_ * std::tanh(kappa_ * t + phi_);
}

double SleighExact::turn_rate(double t) const {
  if (straight_) return w0_;
  return w0_ * std::cosh(phi_) / std::cosh(kappa_ * t + phi_);
}

double SleighExact::heading(double t) const {
  if (straight_) return th0_ + w0_ * t;
  return th0_ + (w0_ * std::cosh(phi_) / kappa_) *
                    (std::atan(std::sinh(kappa_ * t + phi_)) - std::atan(std::sinh(phi_)));
}

Eigen::Vector2d SleighExact::centre_velocity(double t) const {
  const double v = speed(t), w = turn_rate(t), th = heading(t);
  return {v * std::cos(th) - a_ * w * std::sin(th), v * std::sin(th) + a_ * w * std::cos(th)};
}

std::vector<Eigen::Vector2d> SleighExact::positions(const std::vector<double>& times) const {
  std::vector<Eigen::Vector2d> out;
  out.reserve(times.size());
  Eigen::Vector2d pos(x0_, y0_);
  double t_prev = 0.0;
  for (double t : times) {
    if (t < t_prev) throw std::invalid_argument("SleighExact::positions: times must ascend from 0");
    const int panels = static_cast<int>(std::ceil((t - t_prev) / kPanel));
    const double w = panels > 0 ? (t - t_prev) / panels : 0.0;
    for (int k = 0; k < panels; ++k) {
      const double mid = t_prev + (k + 0.5) * w;
      for (int g = 0; g < 8; ++g) pos += 0.5 * w * kWeights[g] * centre_velocity(mid + 0.5 * w * kNodes[g]);
    }
    out.push_back(pos);
    t_prev = t;
  }
  return out;
}

Eigen::Vector3d SleighExact::configuration(double t) const {
  const Eigen::Vector2d c = positions({t}).front();
  return {c.x(), c.y(), heading(t)};
}

ParticleExact::ParticleExact(double x0, double y0, double z0, double xdot0, double ydot0)
    : x0_(x0), y0_(y0), z0_(z0), yd_(ydot0), k_(xdot0 * std::sqrt(1.0 + y0 * y0)) {
  if (ydot0 == 0.0) throw std::invalid_argument("ParticleExact: needs ydot0 != 0");
}

Eigen::Vector3d ParticleExact::configuration(double t) const {
  const double y = y0_ + yd_ * t;
  return {x0_ + (k_ / yd_) * (std::asinh(y) - std::asinh(y0_)), y,
          z0_ + (k_ / yd_) * (std::sqrt(1.0 + y * y) - std::sqrt(1.0 + y0_ * y0_))};
}

Eigen::Vector3d ParticleExact::velocity(double t) const {
  const double y = y0_ + yd_ * t;
  const double xd = k_ / std::sqrt(1.0 + y * y);
  return {xd, yd_, y * xd};
}

SuslovExact::SuslovExact(const Eigen::Matrix3d& inertia, const Eigen::Vector3d& omega0) {
  if (inertia(0, 1) != 0.0 || omega0.z() != 0.0 || omega0.norm() == 0.0)
    throw std::invalid_argument("SuslovExact: needs I12 = 0 and an initial Omega = (w1, w2, 0) != 0");
  const double i1 = inertia(0, 0), i2 = inertia(1, 1), i13 = inertia(0, 2), i23 = inertia(1, 2);
  energy_ = 0.5 * (i1 * omega0.x() * omega0.x() + i2 * omega0.y() * omega0.y());
  c1_ = std::sqrt(2.0 * energy_ / i1);
  c2_ = std::sqrt(2.0 * energy_ / i2);
  phi0_ = std::atan2(i23 * c2_, i13 * c1_);
  kappa_ = std::hypot(i13 * c1_, i23 * c2_) / std::sqrt(i1 * i2);
  const double phi = std::atan2(omega0.y() / c2_, omega0.x() / c1_);
  s0_ = std::sin(phi - phi0_);
}

Eigen::Vector3d SuslovExact::angular_velocity(double t) const {
  // psi in (-pi/2, pi/2) on the branch through psi0 (|sin psi0| < 1 for a motion not yet steady).
  const double psi = std::asin(std::tanh(kappa_ * t + std::atanh(s0_)));
  const double phi = psi + phi0_;
  return {c1_ * std::cos(phi), c2_ * std::sin(phi), 0.0};
}

std::vector<Eigen::Vector4d> SuslovExact::orientations(const Eigen::Vector4d& q0, const std::vector<double>& times) const {
  auto rate = [this](double t, const Eigen::Vector4d& q) {
    const Eigen::Vector3d w = 0.5 * angular_velocity(t);
    return Eigen::Vector4d(-q[1] * w.x() - q[2] * w.y() - q[3] * w.z(), q[0] * w.x() + q[2] * w.z() - q[3] * w.y(),
                           q[0] * w.y() - q[1] * w.z() + q[3] * w.x(), q[0] * w.z() + q[1] * w.y() - q[2] * w.x());
  };
  std::vector<Eigen::Vector4d> out;
  Eigen::Vector4d q = q0 / q0.norm();
  double t = 0.0;
  for (double target : times) {
    const long steps = std::max(1L, static_cast<long>(std::ceil((target - t) / 1e-4)));
    const double h = (target - t) / static_cast<double>(steps);
    for (long k = 0; k < steps; ++k) {
      const Eigen::Vector4d k1 = rate(t, q), k2 = rate(t + 0.5 * h, q + 0.5 * h * k1),
                            k3 = rate(t + 0.5 * h, q + 0.5 * h * k2), k4 = rate(t + h, q + h * k3);
      q += (h / 6.0) * (k1 + 2.0 * k2 + 2.0 * k3 + k4);
      q /= q.norm();
      t = target - h * static_cast<double>(steps - k - 1);
    }
    t = target;
    out.push_back(q);
  }
  return out;
}

}  // namespace nonholo::scenarios
