#pragma once
/// @file
/// 3-D rigid bodies on SO(3) x R^d (the paper's section 4). A rigid body's configuration is its
/// orientation R, stored as a unit quaternion (w, x, y, z), and the position of its centre of
/// mass in R^d, d = translation in {0 (a fixed point), 2 (the centre moves in a horizontal
/// plane), 3 (free)}: 4 + d configuration entries. Its velocities are left-trivialised: the
/// angular velocity Omega in the body frame (R^T Rdot = hat(Omega)), then the centre's velocity
/// in space: 3 + d entries. Momenta are p = M v with M = blockdiag(I, m Id), I the central
/// inertia in the body frame (any SPD matrix, not only a diagonal one). Torques act in the
/// body frame, forces in space. Add one with ModelBuilder::add_rigid_body.
#include <nonholo/build_config.hpp>

#include <Eigen/Core>

#include <string>

namespace nonholo {

/// A 3-D rigid body to add (ModelBuilder::add_rigid_body; see rigid_body.hpp).
struct RigidBody {
  double mass = 1.0;                                       ///< m > 0
  Eigen::Matrix3d inertia = Eigen::Matrix3d::Identity();  ///< central inertia, body frame, SPD
  int translation = 0;                                     ///< d: 0, 2 or 3
  /// The suffix of its coordinate names: `qw<name>`, `qx<name>`, `qy<name>`, `qz<name>`, `x<name>`,
  /// `y<name>`, `z<name>` (configuration) and `wx<name>`, `wy<name>`, `wz<name>`, `vx<name>`, `vy<name>`,
  /// `vz<name>` (velocity). Empty: the body's index.
  std::string name;
  /// Accept principal moments that break the triangle inequality (one larger than the sum of
  /// the other two). No rigid body has them: I = sum m_k (|r_k|^2 Id - r_k r_k^T) gives
  /// I_1 + I_2 - I_3 = 2 sum m_k z_k^2 >= 0 in its principal frame, and the Moser-Veselov
  /// J_d = tr(I)/2 - I is then indefinite. Off (the default): the builder refuses them, naming
  /// the moments.
  bool any_inertia = false;
};

/// The unit quaternion (w, x, y, z) of the rotation by `angle` about `axis` (normalised here;
/// throws std::invalid_argument for a zero or non-finite axis).
Eigen::Vector4d axis_angle_quaternion(const Eigen::Vector3d& axis, double angle);
/// The rotation matrix of the quaternion q / |q| (R x = q x q^*).
Eigen::Matrix3d quaternion_matrix(const Eigen::Vector4d& q);

}  // namespace nonholo
