// The scenes as docs/design.md section 5 defines them: coordinates, metric, one-form rows
// (checked against their geometric meaning), analytic bias terms against a finite
// difference of the rows, and parameter handling.
#include <nonholo/dynamics.hpp>
#include <nonholo/rattle.hpp>
#include <nonholo/scenarios/scene.hpp>
#include <nonholo/start.hpp>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <iostream>

#include "support/dense_reference.hpp"
#include "support/expect_error.hpp"
#include "support/random_model.hpp"

namespace nonholo {
namespace {

scenarios::SceneSetup build(const std::string& name, const std::vector<std::string>& assignments = {}) {
  const auto& info = scenarios::find_scene(name);
  scenarios::Parameters p = info.defaults();
  for (const auto& a : assignments) p.assign(a);
  return info.build(p);
}

TEST(Scenes, CoordinatesAndMetrics) {
  auto sleigh = build("sleigh", {"m=2", "I=3"});
  EXPECT_EQ(sleigh.model.coordinate_names(), (std::vector<std::string>{"x", "y", "theta"}));
  EXPECT_EQ(testing::dense_mass(sleigh.model), Eigen::Vector3d(2, 2, 3).asDiagonal().toDenseMatrix());
  auto particle = build("particle");
  EXPECT_EQ(particle.model.coordinate_names(), (std::vector<std::string>{"x", "y", "z"}));
  EXPECT_EQ(testing::dense_mass(particle.model), Eigen::Matrix3d::Identity());
  auto board = build("snakeboard", {"m=2", "J=0.3", "J0=0.4", "J1=0.05"});
  EXPECT_EQ(board.model.coordinate_names(), (std::vector<std::string>{"x", "y", "theta", "psi", "phi"}));
  Eigen::VectorXd diag(5);
  diag << 2, 2, 0.4, 0.4, 0.1;
  EXPECT_LE((testing::dense_mass(board.model) - Eigen::MatrixXd(diag.asDiagonal())).norm(), 1e-15);
}

TEST(Scenes, SleighBladeCannotSlideSideways) {
  // Blade point C - a e(theta); its velocity Cdot - a thetadot e_perp must be along e(theta).
  auto s = build("sleigh", {"a=0.3"});
  const Eigen::Vector3d q(0.4, -1.0, 0.7), v(0.3, -0.2, 1.1);
  const Eigen::MatrixXd mu = testing::dense_one_forms(s.model, q);
  const Eigen::Vector2d e(std::cos(q[2]), std::sin(q[2])), e_perp(-std::sin(q[2]), std::cos(q[2]));
  const Eigen::Vector2d blade_velocity = v.head<2>() - 0.3 * v[2] * e_perp;
  const double lateral = blade_velocity.dot(e_perp);
  EXPECT_NEAR((mu * v)(0), -lateral, 1e-15);
}

TEST(Scenes, SnakeboardWheelsCannotSlideSideways) {
  // Row 0: the axle at centre - r e(theta), turned by +phi; row 1: the axle at centre +
  // r e(theta), turned by -phi. A wheel's velocity has no component along its axle's normal.
  auto s = build("snakeboard", {"r=0.6"});
  Eigen::VectorXd q(5), v(5);
  q << 0.2, 0.1, 0.5, 0.0, 0.3;
  v << 0.4, -0.7, 0.9, 2.0, -1.0;
  const Eigen::MatrixXd mu = testing::dense_one_forms(s.model, q);
  for (int wheel = 0; wheel < 2; ++wheel) {
    const double side = wheel == 0 ? -1.0 : 1.0;
    const double th = q[2], heading = th - side * q[4];
    const Eigen::Vector2d wheel_velocity =
        v.head<2>() + side * 0.6 * v[2] * Eigen::Vector2d(-std::sin(th), std::cos(th));
    const Eigen::Vector2d normal(-std::sin(heading), std::cos(heading));
    EXPECT_NEAR((mu * v)(wheel), -wheel_velocity.dot(normal), 1e-15) << "wheel " << wheel;
  }
}

TEST(Scenes, AnalyticBiasMatchesFiniteDifferences) {
  for (const auto& info : scenarios::scene_catalogue()) {
    auto s = info.build(info.defaults());
    Workspace ws(s.model);
    const int n = s.model.num_velocities(), nq = s.model.num_configuration(), m = s.model.num_one_forms();
    for (std::uint32_t seed = 1; seed <= 5; ++seed) {
      Vector q = testing::random_vector(seed, nq);
      for (const RigidBlock& r : s.model.rigid_bodies()) q.segment<4>(r.q).normalize();
      // A disk's centre at its height (it lies on the plane): only its orientation matters here.
      const Vector v = testing::random_vector(seed + 50, n);
      Vector bias(m);
      ASSERT_EQ(one_form_bias(s.model, ws, q, v, bias), Status::Ok);
      // Independent: (mu(q (+) d v) - mu(q (+) -d v)) v / (2 d), along the motion's own curve
      // (q + d v on flat models; R exp(d hat(Omega)) for a rigid body's orientation).
      const double d = 1e-5;
      Vector plus(nq), minus(nq);
      s.model.retract(q, d * v, plus);
      s.model.retract(q, -d * v, minus);
      const Vector fd = (testing::dense_one_forms(s.model, plus) - testing::dense_one_forms(s.model, minus)) * v / (2 * d);
      EXPECT_LE((bias - fd).lpNorm<Eigen::Infinity>(), 1e-8) << info.name << " seed " << seed;
    }
  }
}

TEST(Scenes, SnakeboardControlsAreTheDocumentedTorques) {
  auto s = build("snakeboard", {"u_psi_amp=2", "u_psi_omega=3", "u_psi_phase=0.1", "u_phi_amp=0.5",
                                "u_phi_omega=1.5", "u_phi_phase=-0.2"});
  ASSERT_TRUE(s.model.has_external_force());
  const double t = 0.7;
  const Vector f = testing::dense_applied_force(s.model, t, s.q0);
  const double u_psi = 2 * std::sin(3 * t + 0.1), u_phi = 0.5 * std::sin(1.5 * t - 0.2);
  Eigen::VectorXd expected(5);
  expected << 0, 0, -u_psi, u_psi, u_phi;
  EXPECT_LE((f - expected).norm(), 1e-15);
  EXPECT_FALSE(build("snakeboard").model.has_applied_force()) << "no controls by default";
}

TEST(Scenes, ParametersAreValidated) {
  const auto expect = testing::expect_error<std::invalid_argument>;
  expect([] { build("sleigh", {"mass=2"}); },
         "unknown parameter 'mass' for scene 'sleigh' (parameters: m, I, a, v0, omega0, x0, y0, theta0)");
  expect([] { build("sleigh", {"m=abc"}); }, "--set m=abc: 'abc' is not a number");
  expect([] { build("sleigh", {"m=1.5x"}); }, "'1.5x' is not a number");
  expect([] { build("sleigh", {"m="}); }, "'' is not a number");
  expect([] { build("sleigh", {"m"}); }, "--set 'm': expected NAME=VALUE");
  expect([] { build("sleigh", {"=3"}); }, "expected NAME=VALUE");
  expect([] { build("sleigh", {"m=nan"}); }, "'nan' is not finite");
  expect([] { build("sleigh", {"m=1e999"}); }, "out of the range of a double");
  expect([] { build("sleigh", {"m=-1"}); }, "sleigh: parameter m = -1 must be positive");
  expect([] { build("snakeboard", {"J1=0"}); }, "snakeboard: parameter J1 = 0 must be positive");
  expect([] { scenarios::find_scene("sleighs"); }, "unknown scene 'sleighs' (known: particle, sleigh, sleigh_contact, snakeboard, sleigh_chain, wheeled_train, suslov, veselova, chaplygin_ball, ball_chain, rolling_disk)");
  EXPECT_NO_THROW(build("sleigh", {"m=+2.5", "a=-0.1", "I=1e-3"}));
}

// The paper's controlled snakeboard (section 6): from rest, equal-phase, equal-frequency
// sinusoidal torques on the rider and the axles move it forward with increasing speed.
TEST(Scenes, ControlledSnakeboardMovesForwardWithIncreasingSpeed) {
  const auto& info = scenarios::find_scene("snakeboard");
  auto p = info.defaults();
  for (const char* a : {"v0=0", "psi_dot0=0", "phi_dot0=0", "phi0=-0.5", "u_psi_amp=-0.2", "u_phi_amp=0.04",
                        "u_psi_omega=2", "u_phi_omega=2", "u_psi_phase=1.5707963267948966",
                        "u_phi_phase=1.5707963267948966"})
    p.assign(a);
  const auto setup = info.build(p);
  Workspace ws(setup.model);
  State s = start_from_velocity(setup.model, ws, 0.0, setup.q0, setup.v0);
  double x10 = 0.0;
  for (int k = 1; k <= 2000; ++k) {
    ASSERT_EQ(step(setup.model, ws, s, {0.01}), Status::Ok) << ws.message();
    if (k == 1000) x10 = s.q[0];
  }
  std::cout << "[snakeboard gait] x(10) = " << x10 << ", x(20) = " << s.q[0] << ", y(20) = " << s.q[1] << "\n";
  EXPECT_GT(x10, 1.0);
  EXPECT_GT(s.q[0] - x10, 2.0 * x10) << "faster in the second half";
  EXPECT_LT(std::abs(s.q[1]), 2.0);
}

}  // namespace
}  // namespace nonholo
