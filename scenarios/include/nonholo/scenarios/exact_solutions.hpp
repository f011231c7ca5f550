#pragma once
/// @file
/// Closed-form solutions of docs/design.md §6, independent of the integrators: the
/// oracles of the accuracy tests and the error measurements.
#include <nonholo/build_config.hpp>

#include <Eigen/Core>
#include <vector>

namespace nonholo::scenarios {

/// Chaplygin sleigh with f = 0 (centre-of-mass coordinates). v and omega obey
/// vdot = a omega^2, omegadot = -(m a / J) v omega with J = I + m a^2.
class SleighExact {
 public:
  /// Mass m, inertia I about the centre of mass, blade a behind it; the initial forward speed,
  /// turn rate and configuration.
  SleighExact(double m, double I, double a, double v0, double omega0, double x0, double y0,
              double theta0);
  double speed(double t) const;      ///< forward speed v
  double turn_rate(double t) const;  ///< omega = thetadot
  double heading(double t) const;    ///< theta
  /// Centre of mass at each of the ascending times (t >= 0), by composite Gauss-Legendre
  /// quadrature of xdot + i ydot = (v + i a omega) e^{i theta} (error far below 1e-14).
  std::vector<Eigen::Vector2d> positions(const std::vector<double>& times) const;
  /// (x, y, theta) at one time.
  Eigen::Vector3d configuration(double t) const;

 private:
  Eigen::Vector2d centre_velocity(double t) const;
  double m_, a_, v0_, w0_, x0_, y0_, th0_;
  double c_ = 0, kappa_ = 0, phi_ = 0;
  bool straight_ = false;  // omega0 = 0: uniform straight motion
};

/// Nonholonomic particle (zdot = y xdot, M = I) with ydot0 != 0.
class ParticleExact {
 public:
  /// (xdot0, ydot0) must come with zdot0 = y0 xdot0 (a velocity in D).
  ParticleExact(double x0, double y0, double z0, double xdot0, double ydot0);
  Eigen::Vector3d configuration(double t) const;  ///< (x, y, z) at time t
  Eigen::Vector3d velocity(double t) const;  ///< (xdot, ydot, zdot) at time t

 private:
  double x0_, y0_, z0_, yd_, k_;
};

/// The Suslov top (README "3-D bodies") with the constrained body axis a = e3 and I12 = 0: with
/// E = (I1 Omega1^2 + I2 Omega2^2)/2 and c_i = sqrt(2E / I_i), Omega3 = 0, Omega1 = c1 cos(phi),
/// Omega2 = c2 sin(phi), psi = phi - phi0 with phi0 = atan2(I23 c2, I13 c1) obeys
/// psidot = kappa cos(psi), sin(psi(t)) = tanh(kappa t + artanh sin(psi0)),
/// kappa = sqrt((I13 c1)^2 + (I23 c2)^2) / sqrt(I1 I2): the body settles into a steady rotation,
/// attracted at the rate kappa.
class SuslovExact {
 public:
  /// Throws std::invalid_argument unless I12 = 0, omega0_3 = 0 and omega0 != 0.
  SuslovExact(const Eigen::Matrix3d& inertia, const Eigen::Vector3d& omega0);
  Eigen::Vector3d angular_velocity(double t) const;  ///< Omega(t), body frame
  double kappa() const { return kappa_; }  ///< the rate kappa of the attraction
  double energy() const { return energy_; }  ///< E
  /// The orientation at each ascending time t >= 0 from q0 (a unit quaternion (w, x, y, z)):
  /// RK4 with steps of at most 1e-4 on qdot = q (x) (0, Omega(t)) / 2, renormalised (error
  /// about 1e-14 at t = 10).
  std::vector<Eigen::Vector4d> orientations(const Eigen::Vector4d& q0, const std::vector<double>& times) const;

 private:
  double c1_ = 0, c2_ = 0, phi0_ = 0, kappa_ = 0, energy_ = 0, s0_ = 0;
};

}  // namespace nonholo::scenarios
