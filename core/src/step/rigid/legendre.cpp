// The discrete Legendre transforms of legendre.hpp, one function per discrete Lagrangian.
#include "step/rigid/legendre.hpp"

#include <Eigen/LU>

#include <cmath>
#include <limits>

namespace nonholo::detail {
namespace {

constexpr double kEps = std::numeric_limits<double>::epsilon();
constexpr double kQuarterTurn = 1.5707963267948966;  // pi / 2

bool finite(const Vec3& v) { return std::isfinite(v.x()) && std::isfinite(v.y()) && std::isfinite(v.z()); }

// One Newton update x -= J^-1 r, J^-1 from its adjugate (one division); false for a singular
// or non-finite Jacobian. Sets `dx2` to the update's squared norm and `det` to det J.
bool newton_update(const Mat3& j, const Vec3& r, Vec3& x, double& dx2, double& det) {
  const Vec3 c0 = j.col(1).cross(j.col(2)), c1 = j.col(2).cross(j.col(0)), c2 = j.col(0).cross(j.col(1));
  det = j.col(0).dot(c0);
  if (!(std::abs(det) > 0.0) || !std::isfinite(det)) return false;
  const Vec3 dx = Vec3(c0.dot(r), c1.dot(r), c2.dot(r)) / det;  // rows of J^-1 are the c_i / det
  x -= dx;
  dx2 = dx.squaredNorm();
  return finite(x);
}

// When Newton has converged to round-off (squared norms: no square roots in the iteration): the
// update is below 4 eps of the unknown, or it stopped shrinking (more than half the last one)
// while below sqrt(eps) of it. From there quadratic convergence would cut it to round-off at
// once, so what is left is the noise of evaluating the residual, which grows with the spread of
// I's entries: a turned 1:10:10.5 body cycled at 1e-15 of v for all 40 iterations and failed,
// at h |Omega| = 0.001 (issue 36).
struct RoundOff {
  double last = std::numeric_limits<double>::infinity();
  bool reached(double dx2, const Vec3& x) {
    const double x2 = x.squaredNorm();
    const bool done = dx2 <= 16.0 * kEps * kEps * x2 || (dx2 > 0.25 * last && dx2 <= kEps * x2);
    last = dx2;
    return done;
  }
};

// --- Moser-Veselov: 2 (I v + v x I v) = h p (1 + |v|^2) --------------------------------------
// (An isotropic body: isotropic_moser_veselov, legendre.hpp.)
bool solve_moser_veselov(const RigidBlock& b, const Vec3& hp, Vec3& v, int& iterations) {
  iterations = 0;
  v = 0.5 * (b.inverse_inertia * hp);
  double det = 0.0;
  RoundOff converged;
  for (;;) {
    const Vec3 iv = b.inertia * v;
    const Vec3 lhs = 2.0 * (iv + v.cross(iv)), rhs = hp * (1.0 + v.squaredNorm());
    const Vec3 r = lhs - rhs;
    // Solved to round-off once the residual is a few ulps of the terms it balances (the
    // confirming iteration then needs no Jacobian); the update test below is the fallback.
    if (iterations > 0 && r.cwiseAbs().maxCoeff() <= 4.0 * kEps * std::max(lhs.cwiseAbs().maxCoeff(), rhs.cwiseAbs().maxCoeff()))
      break;
    Mat3 jacobian;  // 2 (I + hat(v) I - hat(I v)) - 2 h p v^T
    for (int c = 0; c < 3; ++c) jacobian.col(c) = 2.0 * (b.inertia.col(c) + v.cross(b.inertia.col(c)) - hp * v[c]);
    jacobian -= 2.0 * hat(iv);
    double dx2 = 0.0;
    if (iterations == kMaxLegendreIterations || !newton_update(jacobian, r, v, dx2, det)) return false;
    ++iterations;
    if (converged.reached(dx2, v)) break;
  }
  // On the branch through v = 0 the map's Jacobian keeps the sign it has there (det 8 det I > 0);
  // beyond the fold (h |Omega| past about 1) Newton can only find the other branch. (det is of
  // the last iterate but one, a round-off away from the root.)
  return det > 0.0;
}

// --- MV-F: (alpha / sin alpha) 2 (I v + v x I v) = h p (1 + |v|^2),
//     alpha = arccos(1 - t), t = 2 v^T I v / (c (1 + |v|^2)), c = tr(I) / 3 -----------------
// phi = alpha / sin(alpha) and psi = dphi/dt = (sin(alpha) - alpha cos(alpha)) / sin(alpha)^3.
void mvf_factors(double alpha, double& phi, double& psi) {
  if (alpha < 1e-3) {  // series: the next terms are below 1e-18 (phi) and 1e-12 (psi, a slope only)
    const double a2 = alpha * alpha;
    phi = 1.0 + a2 / 6.0 + 7.0 * a2 * a2 / 360.0;
    psi = 1.0 / 3.0 + 2.0 * a2 / 15.0;
    return;
  }
  const double s = std::sin(alpha), c = std::cos(alpha);
  phi = alpha / s;
  psi = (s - alpha * c) / (s * s * s);
}

bool solve_moser_veselov_f(const RigidBlock& b, const Vec3& hp, Vec3& v, int& iterations) {
  iterations = 0;
  const double c = b.inertia.trace() / 3.0;
  if (b.isotropic) {  // exact on the free rotation: angle = h |p| / J about p
    const double angle = hp.norm() / c;
    if (!(angle <= kQuarterTurn)) return false;
    v = angle > 0.0 ? Vec3((std::tan(0.5 * angle) / hp.norm()) * hp) : Vec3::Zero();
    return true;
  }
  v = 0.5 * (b.inverse_inertia * hp);
  RoundOff converged;
  for (;;) {
    const Vec3 iv = b.inertia * v;
    const double n = v.dot(iv), d = 1.0 + v.squaredNorm();
    const double t = 2.0 * n / (c * d);
    if (!(t < 2.0)) return false;
    const double alpha = std::acos(1.0 - t);
    double phi = 1.0, psi = 0.0;
    mvf_factors(alpha, phi, psi);
    const Vec3 m = 2.0 * (iv + v.cross(iv));
    const Vec3 r = phi * m - hp * d;
    const Vec3 grad_t = (4.0 / (c * d)) * (iv - (n / d) * v);
    const Mat3 jacobian = phi * 2.0 * (b.inertia + hat(v) * b.inertia - hat(iv)) + psi * m * grad_t.transpose() -
                          2.0 * hp * v.transpose();
    double dx2 = 0.0, det = 0.0;
    if (iterations == kMaxLegendreIterations || !newton_update(jacobian, r, v, dx2, det)) return false;
    ++iterations;
    if (converged.reached(dx2, v)) break;
  }
  return v.squaredNorm() <= 1.0;  // at most a quarter turn per step (2 atan |v|)
}

// --- exponential: I xi = dexp_{-xi}(h p), dexp_{-xi} y = y - a xi x y + b xi x (xi x y) -------
// a = (1 - cos th) / th^2, b = (th - sin th) / th^3 and their derivatives over th, th = |xi|.
void dexp_factors(double th, double& a, double& b, double& da, double& db) {
  const double t2 = th * th;
  if (th < 0.1) {  // series (b's closed form loses 6 eps / th^2 to cancellation)
    a = 0.5 - t2 / 24.0 + t2 * t2 / 720.0 - t2 * t2 * t2 / 40320.0;
    b = 1.0 / 6.0 - t2 / 120.0 + t2 * t2 / 5040.0 - t2 * t2 * t2 / 362880.0 + t2 * t2 * t2 * t2 / 39916800.0;
    da = -1.0 / 12.0 + t2 / 180.0 - t2 * t2 / 6720.0;  // (da/dth) / th
    db = -1.0 / 60.0 + t2 / 1260.0 - t2 * t2 / 60480.0;  // (db/dth) / th
    return;
  }
  const double s = std::sin(th), half = std::sin(0.5 * th);
  const double one_minus_cos = 2.0 * half * half;
  a = one_minus_cos / t2;
  b = (th - s) / (t2 * th);
  da = (th * s - 2.0 * one_minus_cos) / (t2 * t2);
  db = (one_minus_cos * th - 3.0 * (th - s)) / (t2 * t2 * th);
}

bool solve_exponential(const RigidBlock& b, const Vec3& hp, Vec3& xi, int& iterations) {
  iterations = 0;
  if (b.isotropic) {  // xi parallel to p: I xi = h p
    xi = hp / b.inertia(0, 0);
    return xi.norm() <= kQuarterTurn;
  }
  xi = b.inverse_inertia * hp;
  RoundOff converged;
  for (;;) {
    double a = 0.0, bb = 0.0, da = 0.0, db = 0.0;
    dexp_factors(xi.norm(), a, bb, da, db);
    const Vec3 xy = xi.cross(hp), xxy = xi.cross(xy);
    const Vec3 r = b.inertia * xi - (hp - a * xy + bb * xxy);
    const Mat3 d_dexp = a * hat(hp) - da * xy * xi.transpose() +
                        bb * (xi.dot(hp) * Mat3::Identity() + xi * hp.transpose() - 2.0 * hp * xi.transpose()) +
                        db * xxy * xi.transpose();
    double dx2 = 0.0, det = 0.0;
    if (iterations == kMaxLegendreIterations || !newton_update(b.inertia - d_dexp, r, xi, dx2, det)) return false;
    ++iterations;
    if (converged.reached(dx2, xi)) break;
  }
  return xi.norm() <= kQuarterTurn;
}

}  // namespace

bool solve_legendre(RotationLagrangian rotation, const RigidBlock& body, double h, const Vec3& p, Vec4& w,
                    int& iterations) {
  const Vec3 hp = h * p;
  iterations = 0;
  if (!finite(hp)) return false;
  if (hp.x() == 0.0 && hp.y() == 0.0 && hp.z() == 0.0) {
    w = Vec4(1.0, 0.0, 0.0, 0.0);
    return true;
  }
  if (body.scale_exponent != 0) {
    // Every transform is homogeneous in (I, h p): solved for the body divided by 2^e, exactly,
    // the same rotation (a ball of mass and inertia 1e-150 or 1e160 failed here, blamed on h).
    RigidBlock unit = body;
    unit.inertia *= std::ldexp(1.0, -body.scale_exponent);
    unit.inverse_inertia *= std::ldexp(1.0, body.scale_exponent);
    unit.scale_exponent = 0;
    return solve_legendre(rotation, unit, 1.0, std::ldexp(1.0, -body.scale_exponent) * hp, w, iterations);
  }
  Vec3 x;
  switch (rotation) {
    case RotationLagrangian::MoserVeselov:
      if (body.isotropic) {
        if (!isotropic_moser_veselov(body.inertia(0, 0), hp, w)) return false;
        w *= 1.0 / w.norm();
        return true;
      }
      if (!solve_moser_veselov(body, hp, x, iterations)) return false;
      w = quaternion_cayley(x);
      return true;
    case RotationLagrangian::MoserVeselovF:
      if (!solve_moser_veselov_f(body, hp, x, iterations)) return false;
      w = quaternion_cayley(x);
      return true;
    case RotationLagrangian::Exponential:
      if (!solve_exponential(body, hp, x, iterations)) return false;
      w = quaternion_exp(x);
      return true;
  }
  return false;
}

Vec3 legendre_momentum(RotationLagrangian rotation, const RigidBlock& b, double h, const Vec4& w) {
  if (rotation == RotationLagrangian::Exponential) {
    const double s = w.tail<3>().norm();
    const double angle = 2.0 * std::atan2(s, w[0]);
    const Vec3 xi = s > 0.0 ? Vec3((angle / s) * w.tail<3>()) : Vec3::Zero();
    double a = 0.0, bb = 0.0, da = 0.0, db = 0.0;
    dexp_factors(xi.norm(), a, bb, da, db);
    const Mat3 dexp_minus = Mat3::Identity() - a * hat(xi) + bb * hat(xi) * hat(xi);
    return dexp_minus.inverse() * (b.inertia * xi) / h;
  }
  const Vec3 v = w.tail<3>() / w[0];
  const Vec3 iv = b.inertia * v;
  const double d = 1.0 + v.squaredNorm();
  Vec3 hp = 2.0 * (iv + v.cross(iv)) / d;
  if (rotation == RotationLagrangian::MoserVeselovF) {
    const double t = 2.0 * v.dot(iv) / (b.inertia.trace() / 3.0 * d);
    double phi = 1.0, psi = 0.0;
    mvf_factors(std::acos(1.0 - t), phi, psi);
    hp *= phi;
  }
  return hp / h;
}

}  // namespace nonholo::detail
