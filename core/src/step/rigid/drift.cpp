// The per-body drift of models with rigid bodies (drift.hpp).
#include "step/rigid/drift.hpp"

#include <nonholo/dynamics.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>

#include "step/rigid/legendre.hpp"

namespace nonholo::detail {
namespace {

Vec4 quaternion_at(const double* q) { return {q[0], q[1], q[2], q[3]}; }
Vec3 vector_at(const double* v) { return {v[0], v[1], v[2]}; }

}  // namespace

int drift(const Model& model, RotationLagrangian rotation, double h, const double* q, const double* p,
          const double* velocity, double* q_out, double* p_out, int& iterations) {
  iterations = 0;
  const auto& rigid = model.rigid_bodies();
  std::size_t next = 0;  // the next rigid body, in body order
  for (int b = 0; b < model.num_bodies(); ++b) {
    const Body& body = model.body(b);
    if (body.kind != BodyKind::Rigid) {
      for (int i = 0; i < body.size; ++i) {
        q_out[body.q_offset + i] = q[body.q_offset + i] + h * velocity[body.offset + i];
        if (p_out) p_out[body.offset + i] = p[body.offset + i];
      }
      continue;
    }
    const RigidBlock& r = rigid[next++];
    Vec4 w;
    int taken = 0;
    const Vec3 p_omega = vector_at(p + r.v);
    if (!solve_legendre(rotation, r, h, p_omega, w, taken)) return b;
    iterations = std::max(iterations, taken);
    const Vec4 turned = compose_normalised(quaternion_at(q + r.q), w);
    for (int i = 0; i < 4; ++i) q_out[r.q + i] = turned[i];
    if (p_out) {  // p_Omega <- W^T p_Omega; an isotropic body turns about p_Omega itself: W^T p = p
      const Vec3 arrived = r.isotropic ? p_omega : rotate_back(w, p_omega);
      for (int i = 0; i < 3; ++i) p_out[r.v + i] = arrived[i];
    }
    for (int i = 0; i < r.translation; ++i) {
      q_out[r.q + 4 + i] = q[r.q + 4 + i] + h * velocity[r.v + 3 + i];
      if (p_out) p_out[r.v + 3 + i] = p[r.v + 3 + i];
    }
  }
  return -1;
}

namespace {

// y = W x on one body's velocities, W its block of M^-1 (k entries from `diagonal`, or the
// row-major k x k `block`): BlockDiagonal::multiply's sums, so the same bits.
template <int K>
inline void block_times(const double* diagonal, const double* block, const double* x, double* y) {
  if (diagonal) {
    for (int i = 0; i < K; ++i) y[i] = diagonal[i] * x[i];
    return;
  }
  for (int i = 0; i < K; ++i) {
    double s = 0.0;
    for (int j = 0; j < K; ++j) s += block[i * K + j] * x[j];
    y[i] = s;
  }
}

// drift() and both products with M^-1 of rigid_drift in one pass, body by body, for models whose
// bodies are all rigid with K = 3 + translation velocities each (a ball chain: K = 5): the
// general path streams the momenta and velocities three times. With `kick` (p_k and f_k), p is
// first made p_k + (h/2) f_k in the same pass. On failure returns the body and leaves its
// M^-1 p in `velocity` (the message reads it).
template <int K>
int drift_rigid_only(const Model& model, RotationLagrangian rotation, double h, const double* q, const State* kick,
                     double* p, double* q_out, double* p_out, double* velocity, int& iterations) {
  iterations = 0;
  const sparse::BlockDiagonal& minv = model.inverse_mass();
  const bool diagonal = minv.is_diagonal();
  const bool moser_veselov = rotation == RotationLagrangian::MoserVeselov;
  const double half = 0.5 * h;
  for (const RigidBlock& r : model.rigid_bodies()) {
    const double* w = diagonal ? minv.diagonal() + r.v : nullptr;
    const double* block = diagonal ? nullptr : minv.block_data(r.body);
    double v_in[K], p_at[K];
    if (kick)
      for (int i = 0; i < K; ++i) p[r.v + i] = kick->p[r.v + i] + half * kick->force[r.v + i];
    block_times<K>(w, block, p + r.v, v_in);
    Vec4 turn;
    int taken = 0;
    const Vec3 p_omega = vector_at(p + r.v);
    // An isotropic Moser-Veselov turn unnormalised: the turned orientation's renormalisation
    // takes |u| too (two square roots and one division a body less; the rotation is the same).
    const bool solved = moser_veselov && r.isotropic
                            ? isotropic_moser_veselov(r.inertia(0, 0), h * p_omega, turn)
                            : solve_legendre(rotation, r, h, p_omega, turn, taken);
    if (!solved) {
      for (int i = 0; i < K; ++i) velocity[r.v + i] = v_in[i];
      return r.body;
    }
    iterations = std::max(iterations, taken);
    const Vec4 turned = compose_normalised(quaternion_at(q + r.q), turn);
    for (int i = 0; i < 4; ++i) q_out[r.q + i] = turned[i];
    const Vec3 arrived = r.isotropic ? p_omega : rotate_back(turn, p_omega);
    for (int i = 0; i < 3; ++i) p_at[i] = arrived[i];
    for (int i = 3; i < K; ++i) {
      q_out[r.q + 1 + i] = q[r.q + 1 + i] + h * v_in[i];
      p_at[i] = p[r.v + i];
    }
    for (int i = 0; i < K; ++i) p_out[r.v + i] = p_at[i];
    block_times<K>(w, block, p_at, velocity + r.v);
  }
  return -1;
}

}  // namespace

Status rigid_drift(const Model& model, Workspace& ws, ConstVecRef q, double h, RotationLagrangian rotation,
                   double t, const State* kick) {
  const auto& minv = model.inverse_mass();
  int iterations = 0, failed = -1;
  double* qn = ws.q_next.data();
  double* pa = ws.p_arrive.data();
  double* v = ws.velocity.data();
  switch (model.rigid_only_translation()) {
    case 0:
      failed = drift_rigid_only<3>(model, rotation, h, q.data(), kick, ws.p_half.data(), qn, pa, v, iterations);
      break;
    case 2:
      failed = drift_rigid_only<5>(model, rotation, h, q.data(), kick, ws.p_half.data(), qn, pa, v, iterations);
      break;
    case 3:
      failed = drift_rigid_only<6>(model, rotation, h, q.data(), kick, ws.p_half.data(), qn, pa, v, iterations);
      break;
    default:
      if (kick) ws.p_half = kick->p + (0.5 * h) * kick->force;
      minv.multiply(ws.p_half.data(), v);
      failed = drift(model, rotation, h, q.data(), ws.p_half.data(), v, qn, pa, iterations);
      if (failed < 0) minv.multiply(pa, v);
  }
  if (failed >= 0) {
    const Body& body = model.body(failed);
    const Vec3 omega(ws.velocity[body.offset], ws.velocity[body.offset + 1], ws.velocity[body.offset + 2]);
    // Moser-Veselov folds at h |Omega| about 1 (sin of the turn per step, for an isotropic body);
    // the other two turn by about h |Omega| and stop at a quarter turn.
    const char* limit = rotation == RotationLagrangian::MoserVeselov ? "below about 1" : "below about pi/2";
    // The advice: h |Omega| = 0.5, which every Lagrangian solves for every physical inertia
    // (tests/test_rigid_legendre.cpp sweeps the body shapes up to 1).
    return ws.fail(Status::LegendreNotSolved,
                   "the discrete Legendre transform (%s) of rigid body %d has no solution in the step from "
                   "t = %.17g: h |Omega| = %.3g (h = %g, |Omega| = %.3g); it needs h |Omega| %s (a rotation of "
                   "less than 90 degrees per step): reduce the step size to %.3g or less (h |Omega| = 0.5)",
                   to_string(rotation), failed, t, std::abs(h) * omega.norm(), std::abs(h), omega.norm(), limit,
                   0.5 / omega.norm());
  }
  ws.legendre_iterations = std::max(ws.legendre_iterations, iterations);
  return Status::Ok;
}

double previous_potential(const Model& model, RotationLagrangian rotation, double h, ConstVecRef q,
                          ConstVecRef p_minus, ConstVecRef v_minus, VecRef q_prev) {
  int iterations = 0;
  if (drift(model, rotation, -h, q.data(), p_minus.data(), v_minus.data(), q_prev.data(), nullptr, iterations) >= 0)
    return std::numeric_limits<double>::quiet_NaN();
  return model.potential(q_prev);
}

void discrete_momentum(const Model& model, RotationLagrangian rotation, ConstVecRef q0, ConstVecRef q1, double h,
                       VecRef p) {
  Vector v = Vector::Zero(model.num_velocities());
  for (int b = 0; b < model.num_bodies(); ++b) {
    const Body& body = model.body(b);
    const int flat = body.kind == BodyKind::Rigid ? body.translation : body.size;
    const int skip = body.kind == BodyKind::Rigid ? 4 : 0, vskip = body.kind == BodyKind::Rigid ? 3 : 0;
    for (int i = 0; i < flat; ++i)
      v[body.offset + vskip + i] = (q1[body.q_offset + skip + i] - q0[body.q_offset + skip + i]) / h;
  }
  model.mass().multiply(v.data(), p.data());  // the orientations' entries are 0 so far
  for (const RigidBlock& r : model.rigid_bodies()) {
    const Vec4 a = quaternion_at(q0.data() + r.q), b = quaternion_at(q1.data() + r.q);
    const Vec4 a_conj(a[0], -a[1], -a[2], -a[3]);
    Vec4 w = quaternion_product(a_conj, b);
    w /= w.norm();
    if (w[0] < 0.0) w = -w;  // the same rotation, by the shorter way
    // A step turns a body by less than a quarter turn (legendre.hpp): a pair further apart is
    // no step of the method.
    if (!(w[0] >= std::sqrt(0.5))) {
      std::ostringstream os;
      os.precision(4);
      os << "start: rigid body " << r.body << " turns by " << 2.0 * std::acos(std::min(1.0, w[0])) * 180.0 / M_PI
         << " degrees from q0 to q1; a step turns a body by less than 90 degrees: take q1 closer to q0 (or a "
            "smaller h)";
      throw std::invalid_argument(os.str());
    }
    p.segment<3>(r.v) = legendre_momentum(rotation, r, h, w);
  }
}

}  // namespace nonholo::detail

namespace nonholo {

void gyroscopic_acceleration(const Model& model, ConstVecRef v, VecRef out) {
  out.setZero();
  for (const RigidBlock& r : model.rigid_bodies()) {
    if (r.isotropic) continue;  // (J Omega) x Omega = 0: only round-off to compute
    const detail::Vec3 omega = v.segment<3>(r.v);
    out.segment<3>(r.v) = r.inverse_inertia * (r.inertia * omega).cross(omega);
  }
}

}  // namespace nonholo
