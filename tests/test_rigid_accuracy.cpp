// 3-D rigid bodies, accuracy (docs/guide/rigid-bodies.md): orders 2, 4 and 6 against the Suslov top's
// closed form and against tight ARKODE runs of the index-reduced equations (Chaplygin ball,
// ball chain, rolling disk), the error constant e_R / h^2 of the Moser-Veselov and MV-F
// Lagrangians, the period-2 mode's bursts on the Suslov top with the plain method and its
// control by the default restarts, the two-ball dumbbell against its closed form, and the
// disk's steady circular rolling. The measured numbers are printed.
#include <nonholo/diagnostics.hpp>
#include <nonholo/rattle.hpp>
#include <nonholo/reference/integrators.hpp>
#include <nonholo/rigid_body.hpp>
#include <nonholo/scenarios/exact_solutions.hpp>
#include <nonholo/scenarios/scene.hpp>
#include <nonholo/start.hpp>

#include "support/scenes.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <vector>

namespace nonholo {
namespace {

using testing::scene;

RattleOptions options(double h, int order = 2, const char* restart = "auto",
                      RotationLagrangian rotation = RotationLagrangian::MoserVeselov,
                      HitchMode hitch = HitchMode::Holonomic) {
  RattleOptions o;
  o.h = h;
  o.order = order;
  o.rotation = rotation;
  o.hitch = hitch;
  set_restart(o.restart, restart);
  return o;
}

using testing::state_at;

// The body-frame angular velocity of rigid body 0 in a state (M^-1 p~).
Eigen::Vector3d omega_of(const Model& model, const State& s) {
  Vector v(model.num_velocities());
  model.inverse_mass().multiply(s.p.data(), v.data());
  return v.segment<3>(model.rigid_bodies()[0].v);
}

// |R - R_ref| (Frobenius) for the quaternions of body 0.
double rotation_error(const Vector& q, const Eigen::Vector4d& reference) {
  return (quaternion_matrix(q.head<4>()) - quaternion_matrix(reference)).norm();
}

// The largest difference between two configurations, rotations compared as matrices (a
// quaternion and its negative are one rotation) and the flat entries as they are.
double configuration_error(const Model& model, const Vector& a, const Vector& b) {
  double worst = 0.0;
  for (int i = 0; i < model.num_bodies(); ++i) {
    const Body& body = model.body(i);
    int skip = 0;
    if (body.kind == BodyKind::Rigid) {
      worst = std::max(worst, (quaternion_matrix(a.segment<4>(body.q_offset)) -
                               quaternion_matrix(b.segment<4>(body.q_offset))).cwiseAbs().maxCoeff());
      skip = 4;
    }
    for (int j = skip; j < body.q_size; ++j) worst = std::max(worst, std::abs(a[body.q_offset + j] - b[body.q_offset + j]));
  }
  return worst;
}

// q at T from ARKODE (Verner 6(5)) on the index-reduced equations at 1e-13.
Vector reference_at(const scenarios::SceneSetup& setup, double T) { return testing::reference_at(setup, T, 1e-13); }

// The Suslov top's defaults and its closed form (a = e3, I12 = 0).
scenarios::SuslovExact suslov_exact() {
  Eigen::Matrix3d inertia;
  inertia << 1, 0, .5, 0, 2, .5, .5, .5, 3;
  return scenarios::SuslovExact(inertia, Eigen::Vector3d(1.0, 0.6, 0.0));
}

TEST(RigidAccuracy, SuslovClosedFormIsTheContinuousMotion) {
  // The oracle itself against the index-reduced equations (ARKODE at 1e-13): independent of
  // the reflection step, so the orders below are measured against the right thing.
  const auto setup = scene("suslov");
  const auto exact = suslov_exact();
  EXPECT_NEAR(exact.kappa(), 0.56789, 5e-6);
  EXPECT_NEAR(exact.energy(), 0.86, 1e-15);
  const Vector q = reference_at(setup, 10.0);
  const double e = rotation_error(q, exact.orientations(setup.q0.head<4>(), {10.0})[0]);
  std::printf("Suslov: ARKODE (1e-13) against the closed form at t = 10: |R - R_exact| = %.3g\n", e);
  EXPECT_LT(e, 1e-10);
}

TEST(RigidAccuracy, SuslovOrdersAndErrorConstants) {
  const auto setup = scene("suslov");
  const auto exact = suslov_exact();
  const Eigen::Vector4d r10 = exact.orientations(setup.q0.head<4>(), {10.0})[0];
  // Order 2, plain steps of h and h/2, each Lagrangian: e_R / h^2 and the order.
  struct Expect {
    RotationLagrangian rotation;
    double lo, hi;  // e_R / h^2 at h = 0.01
  };
  for (const Expect& x : {Expect{RotationLagrangian::MoserVeselov, 2.69, 2.72},
                          Expect{RotationLagrangian::MoserVeselovF, 0.45, 0.65},
                          Expect{RotationLagrangian::Exponential, 0.0, 1e9}}) {
    const double e1 = rotation_error(state_at(setup, options(0.01, 2, "auto", x.rotation), 10.0).q, r10);
    const double e2 = rotation_error(state_at(setup, options(0.005, 2, "auto", x.rotation), 10.0).q, r10);
    std::printf("Suslov %s: e_R(T = 10) = %.4g (h = 0.01), %.4g (h = 0.005): e_R/h^2 = %.4f, order %.4f\n",
                to_string(x.rotation), e1, e2, e1 / 1e-4, std::log2(e1 / e2));
    EXPECT_NEAR(std::log2(e1 / e2), 2.0, 0.05) << to_string(x.rotation);
    EXPECT_GE(e1 / 1e-4, x.lo) << to_string(x.rotation);
    EXPECT_LE(e1 / 1e-4, x.hi) << to_string(x.rotation);
  }
  // Orders 4 and 6 (composed double steps) against the closed form.
  for (const auto& [order, H] : {std::pair<int, double>{4, 0.1}, std::pair<int, double>{6, 0.2}}) {
    const double e1 = rotation_error(state_at(setup, options(H, order), 10.0).q, r10);
    const double e2 = rotation_error(state_at(setup, options(H / 2, order), 10.0).q, r10);
    std::printf("Suslov order %d: e_R = %.4g (H = %g), %.4g (H = %g): order %.3f\n", order, e1, H, e2, H / 2,
                std::log2(e1 / e2));
    EXPECT_NEAR(std::log2(e1 / e2), order, order == 4 ? 0.1 : 0.25);
  }
}

// Orders 2, 4 and 6 against ARKODE on the other scenes (in q, rotations as matrices).
void expect_orders(const std::string& name, const std::vector<std::string>& sets, double T, double h2, double h4,
                   double h6, HitchMode hitch = HitchMode::Holonomic, const char* restart = "auto") {
  const auto setup = scene(name, sets);
  const Vector ref = reference_at(setup, T);
  for (const auto& [order, H] : {std::pair<int, double>{2, h2}, std::pair<int, double>{4, h4}, std::pair<int, double>{6, h6}}) {
    RattleOptions o1 = options(H, order, restart), o2 = options(H / 2, order, restart);
    o1.hitch = o2.hitch = hitch;
    const double e1 = configuration_error(setup.model, state_at(setup, o1, T).q, ref);
    const double e2 = configuration_error(setup.model, state_at(setup, o2, T).q, ref);
    std::printf("%s order %d: error %.4g (H = %g), %.4g (H = %g): order %.3f\n", name.c_str(), order, e1, H, e2, H / 2,
                std::log2(e1 / e2));
    const double tolerance = order == 2 ? 0.05 : order == 4 ? 0.1 : 0.25;
    EXPECT_NEAR(std::log2(e1 / e2), order, tolerance) << name << " order " << order;
  }
}

TEST(RigidAccuracy, OrdersOnTheChaplyginBall) { expect_orders("chaplygin_ball", {}, 5.0, 0.02, 0.1, 0.2); }

// A non-diagonal anisotropic ball restarted every 10 steps: the restart that keeps E_post (it
// turns lambda~ onto lambda_s's ray, docs/design.md section 10.3) keeps the orders.
TEST(RigidAccuracy, OrdersOnAnAnisotropicChaplyginBallRestartedEveryTenSteps) {
  expect_orders("chaplygin_ball", testing::inertia_sets(testing::body_shapes()[0].inertia), 5.0, 0.02, 0.1, 0.2,
                HitchMode::Holonomic, "10");
}

// Physical anisotropic bodies are in order 2's asymptotic range at the scenes' default step:
// the ratio of the errors at 2 dt and dt is 4 (measured 2.00 on each, 1.94 on the Veselova
// needle; against ARKODE at 1e-13, T = 5), so no body shape needs a warning about the default
// step. (An inertia that breaks the triangle inequality, 1:10:100 on the ball, reads 1.48 there
// and 1.97 only at dt/4: the run's accuracy check then ends it inaccurate and names a step.)
TEST(RigidAccuracy, PhysicalBodyShapesAreInTheAsymptoticRangeAtTheDefaultStep) {
  for (const char* name : {"suslov", "veselova", "chaplygin_ball"}) {
    for (const auto& shape : testing::body_shapes()) {
      const auto setup = scene(name, testing::inertia_sets(shape.inertia));
      const double dt = scenarios::find_scene(name).default_dt;
      const Vector ref = reference_at(setup, 5.0);
      const double e1 = configuration_error(setup.model, state_at(setup, options(2 * dt), 5.0).q, ref);
      const double e2 = configuration_error(setup.model, state_at(setup, options(dt), 5.0).q, ref);
      std::printf("%s, %s: error %.4g (2 dt), %.4g (dt = %g): order %.3f\n", name, shape.name, e1, e2, dt,
                  std::log2(e1 / e2));
      EXPECT_NEAR(std::log2(e1 / e2), 2.0, 0.1) << name << ", " << shape.name;
    }
  }
}

TEST(RigidAccuracy, OrdersOnTheBallChain) {
  expect_orders("ball_chain", {}, 5.0, 0.02, 0.1, 0.2, HitchMode::OneForm);
  expect_orders("ball_chain", {"I1=0.3", "I3=0.5"}, 5.0, 0.02, 0.1, 0.2, HitchMode::Holonomic);
}

TEST(RigidAccuracy, OrdersOnTheRollingDisk) { expect_orders("rolling_disk", {}, 1.0, 1.0 / 256, 1.0 / 64, 1.0 / 64); }

// The plain method (restart 0) on the Suslov top: the period-2 mode grows at the rate the flow
// contracts and bursts, throwing the body onto the wrong steady rotation while E_post stays
// exact; with the default restarts the error at t = 200 stays tiny.
TEST(RigidAccuracy, SuslovModeBurstsWithThePlainMethodAndNotWithTheDefaults) {
  const auto setup = scene("suslov");
  const auto exact = suslov_exact();
  const double h = 0.01;
  {
    Workspace ws(setup.model);
    State s = start_from_velocity(setup.model, ws, 0.0, setup.q0, setup.v0);
    RattleOptions o = options(h, 2, "0");
    o.restart.monitor_every = 1;
    const double e0 = diagnose(setup.model, ws, s, h).energy_post;
    // Each burst: the time of the amplitude's peak while it is above 0.5.
    std::vector<double> bursts;
    double peak = 0.0, worst_post = 0.0, worst_omega = 0.0;
    for (long k = 0; k < 20000; ++k) {
      ASSERT_EQ(step(setup.model, ws, s, o), Status::Ok) << ws.message();
      const double a = ws.parasitic;
      if (a > 0.5) {
        if (peak == 0.0) bursts.push_back(s.t);
        if (a > peak) {
          peak = a;
          bursts.back() = s.t;
        }
      } else {
        peak = 0.0;
      }
      worst_post = std::max(worst_post, std::abs(diagnose(setup.model, ws, s, h).energy_post - e0) / e0);
      worst_omega = std::max(worst_omega, (omega_of(setup.model, s) - exact.angular_velocity(s.t)).norm());
    }
    std::printf("Suslov, plain method, h = 0.01: the amplitude's bursts peak at t =");
    for (double t : bursts) std::printf(" %.2f", t);
    std::printf("; max |Omega - Omega_exact| %.3g, E_post %.3g\n", worst_omega, worst_post);
    // The prototype's bursts: near t = 32, 95 and 159 (measured here 31.73, 95.50, 159.27); a
    // change to the step's seed of the mode (its O(h^3) size) or its growth moves them.
    ASSERT_EQ(bursts.size(), 3u);
    EXPECT_NEAR(bursts[0], 32.0, 1.0);
    EXPECT_NEAR(bursts[1], 95.0, 1.0);
    EXPECT_NEAR(bursts[2], 159.0, 1.0);
    EXPECT_GT(worst_omega, 1.0);        // the body leaves the closed form ...
    EXPECT_LT(worst_post, 1e-12);       // ... while the post-momentum energy stays exact
  }
  Workspace ws(setup.model);
  State s = start_from_velocity(setup.model, ws, 0.0, setup.q0, setup.v0);
  const double e0 = diagnose(setup.model, ws, s, h).energy_post;
  double worst_post = 0.0;
  for (long k = 0; k < 20000; ++k) {
    ASSERT_EQ(step(setup.model, ws, s, options(h)), Status::Ok) << ws.message();
    worst_post = std::max(worst_post, std::abs(diagnose(setup.model, ws, s, h).energy_post - e0) / e0);
  }
  const double error = (omega_of(setup.model, s) - exact.angular_velocity(200.0)).norm();
  std::printf("Suslov, defaults, h = 0.01: |Omega - Omega_exact| at t = 200 = %.3g after %ld restarts, E_post %.3g\n",
              error, s.restarts, worst_post);
  EXPECT_LE(error, 1e-7);
  EXPECT_LE(worst_post, 1e-13);
  EXPECT_GT(s.restarts, 0);
}

// Two homogeneous balls on a rod: the centres move as two point masses m + J/r^2 on a rigid rod,
// the centre of mass uniformly, the rod turning uniformly.
TEST(RigidAccuracy, DumbbellMovesAsTwoPointMassesOnARod) {
  const auto setup = scene("ball_chain", {"bodies=2"});
  Workspace ws(setup.model);
  const State s0 = start_from_velocity(setup.model, ws, 0.0, setup.q0, setup.v0);
  Vector v0(setup.model.num_velocities());
  setup.model.inverse_mass().multiply(s0.p.data(), v0.data());
  const Eigen::Vector2d x0 = s0.q.segment<2>(4), x1 = s0.q.segment<2>(10);
  const Eigen::Vector2d u0 = v0.segment<2>(3), u1 = v0.segment<2>(8);
  const Eigen::Vector2d c0 = 0.5 * (x0 + x1), vc = 0.5 * (u0 + u1);
  const Eigen::Vector2d d0 = x0 - x1, dd = u0 - u1;
  const double rate = (d0.x() * dd.y() - d0.y() * dd.x()) / d0.squaredNorm(), angle0 = std::atan2(d0.y(), d0.x());
  const double T = 10.0;
  auto error_at = [&](double h, HitchMode hitch) {
    const State s = state_at(setup, options(h, 2, "auto", RotationLagrangian::MoserVeselov, hitch), T);
    const Eigen::Vector2d a = s.q.segment<2>(4), b = s.q.segment<2>(10);
    const Eigen::Vector2d c = c0 + vc * T;
    const double angle = angle0 + rate * T;
    const Eigen::Vector2d d = 1.5 * Eigen::Vector2d(std::cos(angle), std::sin(angle));  // l / 2 = 1.5
    return std::max((a - (c + d)).cwiseAbs().maxCoeff(), (b - (c - d)).cwiseAbs().maxCoeff());
  };
  for (HitchMode hitch : {HitchMode::Holonomic, HitchMode::OneForm}) {
    const double e1 = error_at(0.02, hitch), e2 = error_at(0.01, hitch);
    std::printf("dumbbell (%s rod): centres off by %.3g (h = 0.02), %.3g (h = 0.01) at t = 10: order %.3f\n",
                to_string(hitch), e1, e2, std::log2(e1 / e2));
    EXPECT_NEAR(std::log2(e1 / e2), 2.0, 0.1) << to_string(hitch);
    EXPECT_LT(e2, 1e-3);
  }
  // The centre of mass's velocity, a combination of the exact rolling momenta, does not move.
  const State s = state_at(setup, options(0.01), T);
  Vector v(setup.model.num_velocities());
  setup.model.inverse_mass().multiply(s.p.data(), v.data());
  const double drift = (0.5 * (v.segment<2>(3) + v.segment<2>(8)) - vc).cwiseAbs().maxCoeff();
  std::printf("dumbbell: centre-of-mass velocity moved by %.3g over 1000 steps\n", drift);
  EXPECT_LT(drift, 1e-13);
}

// A disk spinning in place (omega . n = 0, the centre still) precesses steadily at
// Omega_p^2 = 4 g / (r sin beta), beta the tilt of its axis from the vertical: kept to O(h^2).
TEST(RigidAccuracy, DiskSpinningInPlaceKeepsItsTilt) {
  const double beta = 1.0, g = 9.81, r = 1.0;
  const double precession = std::sqrt(4.0 * g / (r * std::sin(beta)));
  const Eigen::Vector4d q = axis_angle_quaternion(Eigen::Vector3d::UnitY(), beta);  // n = (sin b, 0, cos b)
  const Eigen::Matrix3d rot = quaternion_matrix(q);
  const Eigen::Vector3d n = rot.col(2);
  const Eigen::Vector3d omega = precession * (Eigen::Vector3d::UnitZ() - n.z() * n);  // omega . n = 0
  auto s = scene("rolling_disk");  // its model; the start is this one
  s.q0.head<4>() = q;
  s.q0.segment<2>(4).setZero();
  s.q0[6] = r * std::sin(beta);
  s.v0 << rot.transpose() * omega, 0.0, 0.0, 0.0;
  const double T = 2.0;
  auto deviation = [&](double h) {
    Workspace ws(s.model);
    State st = start_from_velocity(s.model, ws, 0.0, s.q0, s.v0);
    double worst = 0.0;
    const RattleOptions o = options(h);
    for (long k = 0; k < std::lround(T / h); ++k) {
      EXPECT_EQ(step(s.model, ws, st, o), Status::Ok) << ws.message();
      const double tilt = std::acos(quaternion_matrix(st.q.head<4>()).col(2).z());
      worst = std::max({worst, std::abs(tilt - beta), st.q.segment<2>(4).norm()});
    }
    return worst;
  };
  const double e1 = deviation(1.0 / 256), e2 = deviation(1.0 / 512);
  std::printf("disk spinning in place (beta = 1, Omega_p = %.4f): tilt and centre off by %.3g (h = 1/256), %.3g "
              "(h = 1/512): order %.3f\n",
              precession, e1, e2, std::log2(e1 / e2));
  EXPECT_NEAR(std::log2(e1 / e2), 2.0, 0.15);
  EXPECT_LT(e2, 1e-3);
}

}  // namespace
}  // namespace nonholo
