// Order 2 on hitched sleigh chains (3 and 10 bodies), in both hitch modes: the scheme's
// configuration at T for h and h/2, compared with a reference, has errors in the ratio 4.
// The reference is independent of the library's integrator and of the chain's analytic bias:
// the index-reduced equations M qdd = f + mu^T lambda, C lambda = -(mu' qdot) - mu M^-1 f,
// assembled densely from the one-form values only, with the bias mu' qdot taken by a
// fourth-order difference of mu along qdot, integrated by classical RK4 at a fine step whose
// own error is checked by halving it.
#include <nonholo/rattle.hpp>
#include <nonholo/scenarios/scene.hpp>
#include <nonholo/start.hpp>

#include "support/dense_reference.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <iostream>
#include <string>

namespace nonholo {
namespace {

using testing::dense_applied_force;
using testing::dense_mass;
using testing::dense_one_forms;

// The index-reduced equations of docs/design.md section 1 in first-order form y = (q, qdot).
class IndexReducedChain {
 public:
  explicit IndexReducedChain(const Model& model)
      : model_(model), n_(model.num_coordinates()), minv_(dense_mass(model).inverse()) {}

  // (mu' qdot) by the 4-point central difference of eps -> mu(q + eps u) qdot along the unit
  // direction u = qdot / |qdot|: truncation ~ eps^4, round-off ~ 1e-16 / eps, both ~1e-12.
  Vector bias(ConstVecRef q, ConstVecRef qdot) const {
    const double speed = qdot.norm();
    if (speed == 0.0) return Vector::Zero(model_.num_one_forms());
    const Vector u = qdot / speed;
    const double e = 1e-3;
    auto mu_at = [&](double s) -> Eigen::MatrixXd { return dense_one_forms(model_, q + s * u); };
    const Eigen::MatrixXd dmu = (mu_at(-2 * e) - 8.0 * mu_at(-e) + 8.0 * mu_at(e) - mu_at(2 * e)) / (12 * e);
    return speed * (dmu * qdot);
  }

  // (qdot, qddot) at (t, q, qdot).
  Vector rate(double t, ConstVecRef y) const {
    const auto q = y.head(n_), qdot = y.tail(n_);
    const Eigen::MatrixXd mu = dense_one_forms(model_, q);
    const Vector f = dense_applied_force(model_, t, q);
    const Eigen::MatrixXd c = mu * minv_ * mu.transpose();
    const Vector lambda = c.ldlt().solve(-bias(q, qdot) - mu * (minv_ * f));
    Vector out(2 * n_);
    out.head(n_) = qdot;
    out.tail(n_) = minv_ * (f + mu.transpose() * lambda);
    return out;
  }

  // Classical RK4 with steps = round((t_end - t0) / h); returns q(t_end).
  Vector integrate(double t0, const Vector& q0, const Vector& qdot0, double t_end, double h) const {
    Vector y(2 * n_);
    y << q0, qdot0;
    const long steps = std::lround((t_end - t0) / h);
    for (long k = 0; k < steps; ++k) {
      const double t = t0 + static_cast<double>(k) * h;
      const Vector k1 = rate(t, y);
      const Vector k2 = rate(t + h / 2, y + (h / 2) * k1);
      const Vector k3 = rate(t + h / 2, y + (h / 2) * k2);
      const Vector k4 = rate(t + h, y + h * k3);
      y += (h / 6) * (k1 + 2.0 * k2 + 2.0 * k3 + k4);
    }
    return y.head(n_);
  }

  const Eigen::MatrixXd& inverse_mass() const { return minv_; }

 private:
  const Model& model_;
  int n_;
  Eigen::MatrixXd minv_;
};

struct ChainCase {
  int bodies;
  HitchMode hitch;
};

std::string case_name(const ::testing::TestParamInfo<ChainCase>& info) {
  return "Bodies" + std::to_string(info.param.bodies) + "_" + to_string(info.param.hitch);
}

class ChainOrder : public ::testing::TestWithParam<ChainCase> {};

double max_gap(const Model& model, const Vector& q) {
  Vector g(model.num_holonomic());
  model.gap(q, g);
  return g.lpNorm<Eigen::Infinity>();
}

TEST_P(ChainOrder, IsSecondOrderAgainstTheIndexReducedEquations) {
  const ChainCase param = GetParam();
  const auto& info = scenarios::find_scene("sleigh_chain");
  scenarios::Parameters p = info.defaults();
  p.set("bodies", static_cast<double>(param.bodies));
  const scenarios::SceneSetup setup = info.build(p);
  const Model& model = setup.model;
  ASSERT_EQ(model.num_holonomic(), 2 * (param.bodies - 1));

  const double t_end = 2.0, h = 0.02, h_ref = 1e-3;

  // The scheme at h and h/2 from the same started state.
  Vector p0;
  auto scheme = [&](double step_size, double& gap) -> Vector {
    Workspace ws(model);
    State s = start_from_velocity(model, ws, setup.t0, setup.q0, setup.v0);
    p0 = s.p;
    RattleOptions o;
    o.h = step_size;
    o.hitch = param.hitch;
    const long steps = std::lround((t_end - setup.t0) / step_size);
    for (long k = 0; k < steps; ++k) {
      const Status st = step(model, ws, s, o);
      if (st != Status::Ok) {
        ADD_FAILURE() << "step " << k << " failed: " << ws.message();
        break;
      }
    }
    EXPECT_NEAR(s.t, t_end, 1e-12);
    gap = max_gap(model, s.q);
    return Vector(s.q);
  };
  double gap1 = 0.0, gap2 = 0.0;
  const Vector q1 = scheme(h, gap1);
  const Vector q2 = scheme(h / 2, gap2);

  // The reference from (q0, M^-1 p~_0), at h_ref and h_ref/2.
  const IndexReducedChain ref(model);
  const Vector qdot0 = ref.inverse_mass() * p0;
  const Vector r1 = ref.integrate(setup.t0, setup.q0, qdot0, t_end, h_ref);
  const Vector r2 = ref.integrate(setup.t0, setup.q0, qdot0, t_end, h_ref / 2);
  const double ref_error = (r1 - r2).lpNorm<Eigen::Infinity>();

  const double e1 = (q1 - r2).lpNorm<Eigen::Infinity>();
  const double e2 = (q2 - r2).lpNorm<Eigen::Infinity>();
  std::cout << "[chain order] bodies=" << param.bodies << " hitch=" << to_string(param.hitch)
            << " T=" << t_end << " e(h=" << h << ")=" << e1 << " e(h=" << h / 2 << ")=" << e2
            << " ratio=" << e1 / e2 << " reference |RK4(h_ref) - RK4(h_ref/2)|=" << ref_error
            << " gap(h)=" << gap1 << " gap(h/2)=" << gap2
            << " reference gap=" << max_gap(model, r2) << "\n";

  EXPECT_LT(ref_error, 1e-3 * e2) << "the reference is not tight enough";
  EXPECT_LT(e1, 1e-3);
  EXPECT_GE(e1 / e2, 3.6);
  EXPECT_LE(e1 / e2, 4.4);
  if (param.hitch == HitchMode::Holonomic) {
    EXPECT_LT(gap1, 1e-10);
    EXPECT_LT(gap2, 1e-10);
  }
}

INSTANTIATE_TEST_SUITE_P(SleighChain, ChainOrder,
                         ::testing::Values(ChainCase{3, HitchMode::OneForm}, ChainCase{3, HitchMode::Holonomic},
                                           ChainCase{10, HitchMode::OneForm},
                                           ChainCase{10, HitchMode::Holonomic}),
                         case_name);

}  // namespace
}  // namespace nonholo
