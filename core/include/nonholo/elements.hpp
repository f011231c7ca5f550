#pragma once
/// @file
/// Local constraint elements (as Simbody and Chrono model constraints): each evaluates its own
/// rows of mu (values, bias, gap) or its own force from its own bodies' coordinates. The first
/// four act on planar bodies whose first three coordinates are (x, y, theta) of the centre of
/// mass (ModelBuilder::add_planar_body), the others on 3-D rigid bodies (nonholo/rigid_body.hpp;
/// their rows are left-trivialised: angular columns in the body frame). A model built from
/// elements needs no one-form callback;
/// when its rows run body by body (each element joins a body to the next one) the explicit
/// step streams through it in one forward and one backward sweep (docs/design.md §7,
/// core/src/step/chain/chain_sweep.cpp). Add them with ModelBuilder::add_knife_edge and friends.
#include <nonholo/build_config.hpp>

#include <Eigen/Core>

#include <functional>

namespace nonholo {

/// A function of time (a thrust's force or torque).
using TimeFunction = std::function<double(double t)>;

/// A blade at C - a e(theta), e = (cos, sin), rolling without side slip: one row
/// [sin theta, -cos theta, a] on (x, y, theta).
struct KnifeEdge {
  int body = 0;      ///< a planar body
  double a = 0.0;    ///< the blade's distance behind the centre of mass
};

/// The rear hitch point of `rear`, C_r - d e(theta_r), held on the front hitch point of
/// `front`, C_f + f e(theta_f): g = C_r - d e_r - C_f - f e_f = 0 (two holonomic rows,
/// x then y).
struct Hitch {
  /// The two planar bodies: `rear`'s rear hitch point is held on `front`'s front one.
  ///@{
  int rear = 0, front = 0;
  ///@}
  /// d: the rear hitch point's distance behind `rear`'s centre; f: the front hitch point's
  /// distance ahead of `front`'s centre.
  ///@{
  double d = 0.0, f = 0.0;
  ///@}
};

/// V = (k/2)(theta_first - theta_second - rest)^2.
struct TorsionalSpring {
  /// The two planar bodies whose angle difference theta_first - theta_second it pulls.
  ///@{
  int first = 0, second = 0;
  ///@}
  double k = 0.0;     ///< stiffness
  double rest = 0.0;  ///< rest angle of theta_first - theta_second (radians)
};

/// A force along the body's heading, force(t) e(theta), and a torque(t) on its angle; either
/// may be empty.
struct Thrust {
  int body = 0;  ///< a planar body
  /// force(t) along the heading, torque(t) on the angle; either may be empty.
  ///@{
  TimeFunction force, torque;
  ///@}
};

// --- on rigid bodies (ModelBuilder::add_rigid_body) ----------------------------------------
/// A vector-valued function of time (a body torque or force).
using TimeVector = std::function<Eigen::Vector3d(double t)>;

/// <Omega, a> = 0 with a fixed in the body (the Suslov problem): one row on Omega, bias 0.
struct BodyAxisConstraint {
  int body = 0;  ///< a rigid body
  Eigen::Vector3d axis = Eigen::Vector3d::UnitZ();  ///< body frame; any finite nonzero vector (normalised)
};

/// <Omega, R^T e> = 0 with e fixed in space (the Veselova problem, e = e3: no spin about the
/// vertical): one row gamma^T = (R^T e)^T on Omega, bias 0.
struct SpaceAxisConstraint {
  int body = 0;  ///< a rigid body
  Eigen::Vector3d axis = Eigen::Vector3d::UnitZ();  ///< space frame; any finite nonzero vector (normalised)
};

/// A ball of radius r with its centre of mass at its geometric centre (the Chaplygin ball)
/// rolling without slipping on the horizontal plane z = 0: xdot = r (R Omega) x e3, two rows
/// [-r (R^T e2)^T | 1 0] and [r (R^T e1)^T | 0 1] on (Omega, xdot, ydot), bias 0. The body's
/// translation must be 2 or 3; with 3, a third, holonomic row keeps the centre at height r
/// (gap z - r, enforced at position level in holonomic mode).
struct RollingBall {
  int body = 0;          ///< a rigid body with translation 2 or 3
  double radius = 1.0;   ///< r
};

/// A thin disk of radius r (its axis the body's e3, its centre of mass at its centre) rolling
/// without slipping on the plane z = 0: xdot + omega x (r u) = 0, omega = R Omega, u the unit
/// vector from the centre to the contact point, u = -(e3 - (n.e3) n) / |e3 - (n.e3) n| with
/// n = R e3: three rows [-r hat(u) R | Id3] on (Omega, xdot). The vertical one is holonomic, the
/// gradient of the height gap z + r u.e3 (enforced at position level in holonomic mode). The
/// body's translation must be 3; a disk lying flat (n = +-e3) has no contact point (the step
/// reports non-finite one-forms).
struct RollingDisk {
  int body = 0;          ///< a rigid body with translation 3
  double radius = 1.0;   ///< r
};

/// A massless rod of length l between the centres of two bodies (planar bodies, or rigid
/// bodies with translation 2 or 3; both with the same): the holonomic constraint
/// (|x_1 - x_2|^2 - l^2) / (2 l) = 0, one row [d^T/l | -d^T/l], d = x_1 - x_2, bias |xdot_1 - xdot_2|^2 / l.
struct Rod {
  /// The two bodies whose centres it joins (x_1 is first's, x_2 second's).
  ///@{
  int first = 0, second = 0;
  ///@}
  double length = 1.0;  ///< l
};

/// A torque on a rigid body, in its body frame, as a function of time.
struct BodyTorque {
  int body = 0;        ///< a rigid body
  TimeVector torque;   ///< the torque at time t, body frame
};

/// A force on a rigid body's centre, in space, as a function of time (components beyond the
/// body's translation, the vertical one of a body that moves in a plane, are ignored: the plane
/// takes them).
struct BodyForce {
  int body = 0;      ///< a rigid body
  TimeVector force;  ///< the force at time t, space frame
};

}  // namespace nonholo
