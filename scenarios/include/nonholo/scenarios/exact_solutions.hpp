#pragma once
// Closed-form solutions of DESIGN.md section 6, independent of the integrators: the
// oracles of the accuracy tests and the error measurements.
#include <Eigen/Core>
#include <vector>

namespace nonholo::scenarios {

// Chaplygin sleigh with f = 0 (centre-of-mass coordinates). v and omega obey
// vdot = a omega^2, omegadot = -(m a / J) v omega with J = I + m a^2.
class SleighExact {
 public:
  SleighExact(double m, double I, double a, double v0, double omega0, double x0, double y0,
              double theta0);
  double speed(double t) const;      // forward speed v
  double turn_rate(double t) const;  // omega = thetadot
  double heading(double t) const;    // theta
  // Centre of mass at each of the ascending times (t >= 0), by composite Gauss-Legendre
  // quadrature of xdot + i ydot = (v + i a omega) e^{i theta} (error far below 1e-14).
  std::vector<Eigen::Vector2d> positions(const std::vector<double>& times) const;
  // (x, y, theta) at one time.
  Eigen::Vector3d configuration(double t) const;

 private:
  Eigen::Vector2d centre_velocity(double t) const;
  double m_, a_, v0_, w0_, x0_, y0_, th0_;
  double c_ = 0, kappa_ = 0, phi_ = 0;
  bool straight_ = false;  // omega0 = 0: uniform straight motion
};

// Nonholonomic particle (zdot = y xdot, M = I) with ydot0 != 0.
class ParticleExact {
 public:
  // (xdot0, ydot0) must come with zdot0 = y0 xdot0 (a velocity in D).
  ParticleExact(double x0, double y0, double z0, double xdot0, double ydot0);
  Eigen::Vector3d configuration(double t) const;
  Eigen::Vector3d velocity(double t) const;

 private:
  double x0_, y0_, z0_, yd_, k_;
};

}  // namespace nonholo::scenarios
