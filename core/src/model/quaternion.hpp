#pragma once
// Unit quaternions (w, x, y, z) for rigid-body orientations: R x = q x q^*, composition
// q_{k+1} = q_k (x) w for a body-frame increment W (R_{k+1} = R_k W). Fixed-size, inline, no
// allocation.
#include <Eigen/Core>
#include <Eigen/Geometry>  // cross products

#include <cmath>

namespace nonholo::detail {

using Vec3 = Eigen::Vector3d;
using Vec4 = Eigen::Vector4d;
using Mat3 = Eigen::Matrix3d;

// hat(v) x = v x x.
inline Mat3 hat(const Vec3& v) {
  Mat3 m;
  m << 0.0, -v.z(), v.y(), v.z(), 0.0, -v.x(), -v.y(), v.x(), 0.0;
  return m;
}

// The Hamilton product a (x) b.
inline Vec4 quaternion_product(const Vec4& a, const Vec4& b) {
  return {a[0] * b[0] - a[1] * b[1] - a[2] * b[2] - a[3] * b[3],
          a[0] * b[1] + a[1] * b[0] + a[2] * b[3] - a[3] * b[2],
          a[0] * b[2] - a[1] * b[3] + a[2] * b[0] + a[3] * b[1],
          a[0] * b[3] + a[1] * b[2] - a[2] * b[1] + a[3] * b[0]};
}

// The rotation matrix of q / |q| (a non-unit quaternion, as an ODE solver carries it, gives
// the rotation it stands for).
inline Mat3 rotation_of(const Vec4& q) {
  const double s = 2.0 / q.squaredNorm();
  const double w = q[0], x = q[1], y = q[2], z = q[3];
  Mat3 r;
  r << 1.0 - s * (y * y + z * z), s * (x * y - w * z), s * (x * z + w * y),  //
      s * (x * y + w * z), 1.0 - s * (x * x + z * z), s * (y * z - w * x),   //
      s * (x * z - w * y), s * (y * z + w * x), 1.0 - s * (x * x + y * y);
  return r;
}

// Row i of rotation_of(q), with the same arithmetic (bit for bit): a ball's rolling row needs
// one row of R, and the whole matrix cost twice its row's work (the general ball-chain step).
inline Vec3 rotation_row(const double* q, int i) {
  const double w = q[0], x = q[1], y = q[2], z = q[3];
  const double s = 2.0 / Vec4(w, x, y, z).squaredNorm();
  switch (i) {
    case 0: return {1.0 - s * (y * y + z * z), s * (x * y - w * z), s * (x * z + w * y)};
    case 1: return {s * (x * y + w * z), 1.0 - s * (x * x + z * z), s * (y * z - w * x)};
    default: return {s * (x * z - w * y), s * (y * z + w * x), 1.0 - s * (x * x + y * y)};
  }
}

// R^T e3 = gamma (the vertical in the body frame), and R^T e1, R^T e2: the rows of R.
inline Vec3 body_vertical(const Mat3& r) { return r.row(2).transpose(); }

// The quaternion of exp(hat(xi)): rotation by |xi| about xi.
inline Vec4 quaternion_exp(const Vec3& xi) {
  const double angle = xi.norm();
  if (angle < 1e-8) {  // sin(a/2)/a = 1/2 - a^2/48: the second term is below round-off here
    const Vec3 u = 0.5 * xi;
    Vec4 q(1.0 - angle * angle / 8.0, u.x(), u.y(), u.z());
    return q / q.norm();
  }
  const double s = std::sin(0.5 * angle) / angle;
  return {std::cos(0.5 * angle), s * xi.x(), s * xi.y(), s * xi.z()};
}

// The unit quaternion of the Cayley transform cay(v): (1, v) / sqrt(1 + |v|^2), the rotation by
// 2 atan |v| about v.
inline Vec4 quaternion_cayley(const Vec3& v) {
  const double s = 1.0 / std::sqrt(1.0 + v.squaredNorm());
  return {s, s * v.x(), s * v.y(), s * v.z()};
}

// R(w)^T x for a unit quaternion w = (s, u): x turned by the conjugate, t = -2 u x x,
// x + s t - u x t (two cross products, no matrix).
inline Vec3 rotate_back(const Vec4& w, const Vec3& x) {
  const Vec3 u(w[1], w[2], w[3]);
  const Vec3 t = -2.0 * u.cross(x);
  return x + w[0] * t - u.cross(t);
}

// q (x) w, renormalised (a product of unit quaternions drifts off the unit sphere by round-off).
// One division, not four: the drift of a ball chain is a third of its holonomic step.
inline Vec4 compose_normalised(const Vec4& q, const Vec4& w) {
  const Vec4 r = quaternion_product(q, w);
  return r * (1.0 / r.norm());
}

}  // namespace nonholo::detail
