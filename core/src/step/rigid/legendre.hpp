#pragma once
// The discrete Legendre transforms of a rigid body's rotation (docs/guide/rigid-bodies.md): the
// body-frame post-momentum p at g_k determines the increment W = R_k^T R_{k+1} of a step of
// signed size h, and the pre-momentum at g_{k+1} is W^T p. For the Moser-Veselov Lagrangian,
// with W = cay(v): 2 (I v + v x I v) = h p (1 + |v|^2), solved by Newton from v = (h/2) I^-1 p
// (closed form for an isotropic body); MV-F multiplies the left side by alpha / sin(alpha); the
// exponential Lagrangian solves I xi = dexp_{-xi}(h p), W = exp(hat(xi)). Allocation-free.
#include <nonholo/model.hpp>
#include <nonholo/rattle_options.hpp>

#include <cmath>

#include "model/quaternion.hpp"

namespace nonholo::detail {

// The Newton iterations stop when the update is below 4 eps of the unknown, or fail after this many.
inline constexpr int kMaxLegendreIterations = 40;

// W (as the unit quaternion w) from the post-momentum p of `body` over the step h. False when
// there is no solution on the branch through W = Id: h |Omega| beyond about 1 (the fold of the
// Moser-Veselov map; a rotation of more than 90 degrees per step for the other two), or a
// non-finite p. `iterations`: Newton iterations taken (0 for the closed forms).
bool solve_legendre(RotationLagrangian rotation, const RigidBlock& body, double h, const Vec3& p, Vec4& w,
                    int& iterations);

// Moser-Veselov for an isotropic body (inertia J Id) in closed form: W turns about p by the angle
// a with sin a = h |p| / J, and cay(v) with v = h p / (J (1 + cos a)) is W; times J (1 + cos a),
// the quaternion u = (J + sqrt(J^2 - |h p|^2), h p) is W unnormalised (one square root, no
// division; the drift folds |u| into the turned orientation's renormalisation). False past the
// fold (h |p| > J) or for a non-finite h p.
inline bool isotropic_moser_veselov(double j, const Vec3& hp, Vec4& u) {
  const double d = j * j - hp.squaredNorm();
  if (!(d >= 0.0)) return false;
  u = Vec4(j + std::sqrt(d), hp.x(), hp.y(), hp.z());
  return true;
}

// The inverse: the post-momentum p that makes a step of size h rotate by W (unit quaternion w
// with w[0] > 0: a rotation of less than 180 degrees). For the start from two configurations.
Vec3 legendre_momentum(RotationLagrangian rotation, const RigidBlock& body, double h, const Vec4& w);

}  // namespace nonholo::detail
