// The local elements on rigid bodies (nonholo/elements.hpp), each evaluating its own rows from
// its own body's quaternion and centre: left-trivialised rows, angular columns in the body frame.
#include "model/element_set.hpp"
#include "model/quaternion.hpp"

namespace nonholo::detail {
namespace {

Mat3 rotation_at(const double* q) { return rotation_of(Vec4(q[0], q[1], q[2], q[3])); }
Vec3 vector_at(const double* v) { return {v[0], v[1], v[2]}; }

// The disk's contact geometry: n = R e3 its axis, w = e3 - (n.e3) n (|w| = sin of the tilt),
// u = -w / |w| the unit vector from the centre to the contact point.
struct DiskContact {
  Mat3 r;
  Vec3 n, w, u;
  double w_norm;
  explicit DiskContact(const double* q) : r(rotation_at(q)) {
    n = r.col(2);
    w = Vec3::UnitZ() - n.z() * n;
    w_norm = w.norm();
    u = -w / w_norm;  // a disk lying flat has no contact point: NaN, reported by the factorisation
  }
};

}  // namespace

void rigid_row_values(const ElementSet& set, const ElementRow& row, const double* q, double* values) {
  switch (row.kind) {
    case ElementRow::BodyAxis: {
      const Vec3& a = set.body_axes[static_cast<std::size_t>(row.element)].axis;
      for (int i = 0; i < 3; ++i) values[i] = a[i];
      return;
    }
    case ElementRow::SpaceAxis: {
      const SpaceAxisConstraint& c = set.space_axes[static_cast<std::size_t>(row.element)];
      const Vec3 gamma = rotation_at(q + set.rigid_body(c.body).q).transpose() * c.axis;
      for (int i = 0; i < 3; ++i) values[i] = gamma[i];
      return;
    }
    case ElementRow::Ball: {  // [-r (R^T e2)^T | 1 0], [r (R^T e1)^T | 0 1], height [1]
      const RollingBall& ball = set.balls[static_cast<std::size_t>(row.element)];
      if (row.part == 2) {
        values[0] = 1.0;
        return;
      }
      const double sign = row.part == 0 ? -ball.radius : ball.radius;
      const Vec3 axis = rotation_row(q + set.rigid_body(ball.body).q, row.part == 0 ? 1 : 0);
      for (int i = 0; i < 3; ++i) values[i] = sign * axis[i];
      values[3] = 1.0;
      return;
    }
    case ElementRow::Disk: {  // row `part` of [-r hat(u) R | Id3]
      const RollingDisk& disk = set.disks[static_cast<std::size_t>(row.element)];
      const DiskContact c(q + set.rigid_body(disk.body).q);
      const Vec3 rowv = -disk.radius * (hat(c.u) * c.r).row(row.part).transpose();
      for (int i = 0; i < 3; ++i) values[i] = rowv[i];
      values[3] = 1.0;
      return;
    }
    case ElementRow::Rod: {  // [d^T / l | -d^T / l], d = x_1 - x_2
      const Rod& rod = set.rods[static_cast<std::size_t>(row.element)];
      const int dim = set.centre_dim(rod.first), a = set.centre_q(rod.first), b = set.centre_q(rod.second);
      for (int i = 0; i < dim; ++i) {
        const double d = (q[a + i] - q[b + i]) / rod.length;
        values[i] = d;
        values[dim + i] = -d;
      }
      return;
    }
    default:
      return;
  }
}

void ElementSet::ball_chain_values(const double* q, double* mu) const {
  ball_chain_values(q, mu, 0, static_cast<int>(balls.size()));
}

void ElementSet::ball_chain_values(const double* q, double* mu, int first, int last) const {
  const int n = static_cast<int>(balls.size());
  for (int b = first; b < last; ++b) {
    const double* qb = q + 6 * b;
    const Vec3 row0 = rotation_row(qb, 0), row1 = rotation_row(qb, 1);
    const double r = balls[static_cast<std::size_t>(b)].radius;
    double* v = mu + 12 * b;
    for (int i = 0; i < 3; ++i) {
      v[i] = -r * row1[i];
      v[4 + i] = r * row0[i];
    }
    v[3] = v[7] = 1.0;
    if (b + 1 < n) {
      const double length = rods[static_cast<std::size_t>(b)].length;
      for (int i = 0; i < 2; ++i) {
        const double d = (qb[4 + i] - qb[10 + i]) / length;
        v[8 + i] = d;
        v[10 + i] = -d;
      }
    }
  }
}

double rigid_row_bias(const ElementSet& set, const ElementRow& row, const double* q, const double* v) {
  switch (row.kind) {
    case ElementRow::Disk: {  // r (omega x udot)_part: the rows' rate along the motion times Omega
      const RollingDisk& disk = set.disks[static_cast<std::size_t>(row.element)];
      const RigidBlock& body = set.rigid_body(disk.body);
      const DiskContact c(q + body.q);
      const Vec3 omega = c.r * vector_at(v + body.v);
      const Vec3 ndot = omega.cross(c.n);
      const Vec3 wdot = -ndot.z() * c.n - c.n.z() * ndot;
      const Vec3 w_hat = c.w / c.w_norm;
      const Vec3 udot = -(wdot - w_hat * w_hat.dot(wdot)) / c.w_norm;
      return disk.radius * omega.cross(udot)[row.part];
    }
    case ElementRow::Rod: {  // |xdot_1 - xdot_2|^2 / l
      const Rod& rod = set.rods[static_cast<std::size_t>(row.element)];
      const int dim = set.centre_dim(rod.first), a = set.centre_v(rod.first), b = set.centre_v(rod.second);
      double s = 0.0;
      for (int i = 0; i < dim; ++i) s += (v[a + i] - v[b + i]) * (v[a + i] - v[b + i]);
      return s / rod.length;
    }
    default:  // the axis constraints and the ball: d/dt of their rows along the motion is 0 on Omega
      return 0.0;
  }
}

double rigid_row_gap(const ElementSet& set, const ElementRow& row, const double* q) {
  switch (row.kind) {
    case ElementRow::Ball: {  // z - r
      const RollingBall& ball = set.balls[static_cast<std::size_t>(row.element)];
      return q[set.rigid_body(ball.body).q + 6] - ball.radius;
    }
    case ElementRow::Disk: {  // z + r u.e3 = z - r |w|
      const RollingDisk& disk = set.disks[static_cast<std::size_t>(row.element)];
      const RigidBlock& body = set.rigid_body(disk.body);
      const DiskContact c(q + body.q);
      return q[body.q + 6] - disk.radius * c.w_norm;
    }
    case ElementRow::Rod: {  // (|d|^2 - l^2) / (2 l)
      const Rod& rod = set.rods[static_cast<std::size_t>(row.element)];
      const int dim = set.centre_dim(rod.first), a = set.centre_q(rod.first), b = set.centre_q(rod.second);
      double s = 0.0;
      for (int i = 0; i < dim; ++i) s += (q[a + i] - q[b + i]) * (q[a + i] - q[b + i]);
      return (s - rod.length * rod.length) / (2.0 * rod.length);
    }
    default:
      return 0.0;
  }
}

void rigid_forces(const ElementSet& set, double t, const double*, double* out) {
  if (set.has_gravity)
    for (const RigidBlock& r : *set.rigid)
      if (r.translation == 3) out[r.v + 5] -= r.mass * set.gravity;
  for (const BodyTorque& tq : set.torques) {
    const Vec3 tau = tq.torque(t);
    const int o = set.rigid_body(tq.body).v;
    for (int i = 0; i < 3; ++i) out[o + i] += tau[i];
  }
  for (const BodyForce& f : set.body_forces) {
    const Vec3 force = f.force(t);
    const RigidBlock& r = set.rigid_body(f.body);
    for (int i = 0; i < r.translation; ++i) out[r.v + 3 + i] += force[i];
  }
}

}  // namespace nonholo::detail
