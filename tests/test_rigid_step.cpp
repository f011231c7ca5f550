// 3-D rigid bodies, the step (docs/guide/rigid-bodies.md): the invariants of every 3-D scene over 10^5
// steps (post-momentum energy, momentum maps, Veselova's integral, constraint residual,
// quaternion norm; the disk's discrete work identity), the exponential Lagrangian's drift where
// Moser-Veselov is exact, the Legendre transform refused beyond its range with the state
// unchanged, a rigid body turning about the vertical against the planar body, the step's
// symmetry, the start from two configurations, a model mixing planar and rigid bodies, one-form
// callbacks against the elements, and the builder's checks.
#include <nonholo/diagnostics.hpp>
#include <nonholo/model_builder.hpp>
#include <nonholo/rattle.hpp>
#include <nonholo/rigid_body.hpp>
#include <nonholo/scenarios/run.hpp>
#include <nonholo/scenarios/scene.hpp>
#include <nonholo/start.hpp>

#include "model/element_set.hpp"
#include "support/rigid_watch.hpp"
#include "support/scenes.hpp"
#include "support/bitwise_equal.hpp"
#include "support/expect_error.hpp"

#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <string>

namespace nonholo {
namespace {

constexpr double kEps = std::numeric_limits<double>::epsilon();

using testing::scene;
using testing::watch;
using testing::Watch;

RattleOptions options(double h, const char* restart = "auto",
                      RotationLagrangian rotation = RotationLagrangian::MoserVeselov,
                      HitchMode hitch = HitchMode::Holonomic) {
  RattleOptions o;
  o.h = h;
  o.rotation = rotation;
  o.hitch = hitch;
  set_restart(o.restart, restart);
  return o;
}

TEST(RigidStep, InvariantsOfEveryThreeDSceneOverTenToTheFiveSteps) {
  struct Case {
    const char* name;
    std::vector<std::string> sets;
    HitchMode hitch;
  };
  for (const Case& c : {Case{"suslov", {}, HitchMode::Holonomic}, Case{"veselova", {}, HitchMode::Holonomic},
                        Case{"chaplygin_ball", {}, HitchMode::Holonomic},
                        // rods as one-forms: the position-level rods do work of their own
                        Case{"ball_chain", {}, HitchMode::OneForm},
                        Case{"ball_chain", {"I1=0.3", "I3=0.5"}, HitchMode::OneForm},
                        // gravity: the discrete work identity, with the height as a one-form
                        Case{"rolling_disk", {}, HitchMode::OneForm}}) {
    const auto setup = scene(c.name, c.sets);
    const double h = scenarios::find_scene(c.name).default_dt;
    const Watch w = watch(setup, options(h, "auto", RotationLagrangian::MoserVeselov, c.hitch), 100000);
    std::printf("%s%s, 1e5 steps of %g: E_post %.3g (work identity with forces), maps %.3g, |mu M^-1 p~| %.3g, "
                "|quaternion| - 1 %.3g, %ld restarts",
                c.name, c.sets.empty() ? "" : " (anisotropic)", h, w.energy_post, w.maps, w.residual, w.norm,
                w.restarts);
    if (std::string(c.name) == "veselova") std::printf(", F %.3g", w.veselova);
    std::printf("\n");
    EXPECT_LE(w.energy_post, 1e-12) << c.name;
    EXPECT_LE(w.maps, 1e-12) << c.name;
    EXPECT_LE(w.residual, 1e-14) << c.name;
    EXPECT_LE(w.norm, 1e-14) << c.name;
    if (std::string(c.name) == "veselova") {
      EXPECT_LE(w.veselova, 1e-12);
    }
    if (std::string(c.name) == "rolling_disk") {
      EXPECT_GT(std::abs(w.work), 1e-3) << "gravity does work: the identity is not trivial";
    }
  }
}

// Restarts at every step (and the composed steps' energy projection) keep the ball chain's N + 2
// momentum maps by scaling only what they do not see; without the declared symmetries the same
// restarts move a ball's spin.
TEST(RigidStep, RestartsKeepTheDeclaredMomentumMaps) {
  auto spin0 = [](const State& s) { return quaternion_matrix(s.q.head<4>()).row(2).dot(s.p.head<3>()); };
  for (int declared : {1, 0}) {
    const auto setup = scene("ball_chain", {"bodies=5", "I1=0.3", "I3=0.5", "symmetries=" + std::to_string(declared)});
    const Model& model = setup.model;
    EXPECT_EQ(model.momentum_maps().size(), declared ? 7u : 0u);
    Workspace ws(model);
    State s = start_from_velocity(model, ws, 0.0, setup.q0, setup.v0);
    RattleOptions o = options(0.01, "auto", RotationLagrangian::MoserVeselov, HitchMode::OneForm);
    o.restart.tolerance = 1e-300;  // a restart at every step
    o.restart.monitor_every = 1;
    const double e0 = diagnose(model, ws, s, 0.01).energy_post, j0 = spin0(s);
    Vector m0(model.momentum_maps().size()), m(model.momentum_maps().size());
    evaluate_momentum_maps(model, s, m0);
    double maps = 0.0, energy = 0.0, spin = 0.0;
    for (int k = 0; k < 2000; ++k) {
      ASSERT_EQ(step(model, ws, s, o), Status::Ok) << ws.message();
      evaluate_momentum_maps(model, s, m);
      if (declared) maps = std::max(maps, (m - m0).lpNorm<Eigen::Infinity>());
      energy = std::max(energy, std::abs(diagnose(model, ws, s, 0.01).energy_post - e0) / e0);
      spin = std::max(spin, std::abs(spin0(s) - j0));
    }
    std::printf("ball chain, 5 Chaplygin balls, restarts at every step (%ld), symmetries %s: maps %.3g, ball 0's spin "
                "%.3g, E_post %.3g\n",
                s.restarts, declared ? "declared" : "not declared", maps, spin, energy);
    EXPECT_EQ(s.restarts, 2000);
    EXPECT_LE(energy, 1e-12);
    if (declared) {
      EXPECT_LE(maps, 1e-12);
      EXPECT_LE(spin, 1e-12);
    } else {
      EXPECT_GE(spin, 1e-10);  // what the declaration saves
    }
  }
  // Order 4: the energy projection at every composed step keeps them too.
  const auto setup = scene("ball_chain", {"bodies=5", "I1=0.3", "I3=0.5"});
  Workspace ws(setup.model);
  State s = start_from_velocity(setup.model, ws, 0.0, setup.q0, setup.v0);
  RattleOptions o = options(0.05, "auto", RotationLagrangian::MoserVeselov, HitchMode::OneForm);
  o.order = 4;
  Vector m0(setup.model.momentum_maps().size()), m(m0.size());
  evaluate_momentum_maps(setup.model, s, m0);
  const double e0 = diagnose(setup.model, ws, s, 0.05).energy;
  double maps = 0.0, energy = 0.0;
  for (int k = 0; k < 400; ++k) {
    ASSERT_EQ(step(setup.model, ws, s, o), Status::Ok) << ws.message();
    evaluate_momentum_maps(setup.model, s, m);
    maps = std::max(maps, (m - m0).lpNorm<Eigen::Infinity>());
    energy = std::max(energy, std::abs(diagnose(setup.model, ws, s, 0.05).energy - e0) / e0);
  }
  std::printf("ball chain, order 4, 400 composed steps: maps %.3g, energy of p~ %.3g\n", maps, energy);
  EXPECT_LE(maps, 1e-12);
  EXPECT_LE(energy, 1e-14);
}

// Moser-Veselov keeps E_post for any inertia; the exponential Lagrangian only for isotropic
// bodies (Theorem 1): a wrong Legendre map would fail the first check as the exponential fails.
TEST(RigidStep, ExponentialLagrangianDriftsWhereMoserVeselovIsExact) {
  const long steps = 10000;
  for (const char* name : {"suslov", "chaplygin_ball"}) {
    const auto setup = scene(name);
    // With the default restarts (energy-exact: they move no energy): the plain method's mode
    // bursts would add the round-off's bias of about 0.2 eps per step (docs/results/behaviour.md).
    const double mv = watch(setup, options(0.01), steps).energy_post;
    const double mvf = watch(setup, options(0.01, "auto", RotationLagrangian::MoserVeselovF), steps).energy_post;
    const double ex = watch(setup, options(0.01, "auto", RotationLagrangian::Exponential), steps).energy_post;
    std::printf("%s, 1e4 steps of 0.01: E_post drift: Moser-Veselov %.3g, MV-F %.3g, exponential %.3g\n", name, mv,
                mvf, ex);
    EXPECT_LE(mv, 1e-13) << name;
    EXPECT_LE(mvf, 1e-13) << name;
    EXPECT_GE(ex, 1e-7) << name;
  }
  // Homogeneous balls: a bi-invariant metric, exact for every Lagrangian (the rods make D
  // non-invariant: the non-trivial case of Theorem 1).
  const auto chain = scene("ball_chain");
  for (RotationLagrangian r :
       {RotationLagrangian::MoserVeselov, RotationLagrangian::MoserVeselovF, RotationLagrangian::Exponential}) {
    const double e = watch(chain, options(0.01, "0", r, HitchMode::OneForm), steps).energy_post;
    std::printf("homogeneous ball chain, %s: E_post drift %.3g\n", to_string(r), e);
    EXPECT_LE(e, 1e-13) << to_string(r);
  }
}

// A rigid body in other units (mass and inertia times 1e-150, 1e160, 2^-400, within the
// builder's range) moves as the unscaled one: the inverse inertia and the Legendre transforms'
// Newton determinant, cubes of the moments, under- or overflowed (refused as "radius of gyration
// 0", or failing at step 1 with "h |Omega| = 0.0229 ... reduce the step size").
TEST(RigidStep, ABodyInOtherUnitsMovesAsTheUnscaledOne) {
  const auto ball = [](double scale) {
    ModelBuilder b;
    RigidBody body;
    body.mass = scale;
    body.translation = 2;
    const Eigen::Matrix3d turn = Eigen::AngleAxisd(0.7, Eigen::Vector3d(1.0, 2.0, 0.5).normalized()).toRotationMatrix();
    body.inertia = scale * turn * Eigen::Vector3d(0.3, 0.4, 0.5).asDiagonal() * turn.transpose();
    b.add_rigid_body(body);
    b.add_rolling_ball({0, 1.0});
    return b.build();
  };
  Vector q0(6), v0(5);
  q0 << 1.0, 0.0, 0.0, 0.0, 0.0, 0.0;
  v0 << 1.0, -0.5, 2.0, 0.3, 0.1;
  for (RotationLagrangian rotation : {RotationLagrangian::MoserVeselov, RotationLagrangian::Exponential}) {
    std::vector<Vector> finals;
    for (double scale : {1.0, 1e-150, 1e160, std::ldexp(1.0, -400)}) {
      SCOPED_TRACE(std::string(to_string(rotation)) + ", scale " + std::to_string(std::log10(scale)));
      const Model m = ball(scale);
      Workspace ws(m);
      State s = start_from_velocity(m, ws, 0.0, q0, v0);
      const RattleOptions o = options(0.01, "auto", rotation);
      for (int k = 0; k < 300; ++k) ASSERT_EQ(step(m, ws, s, o), Status::Ok) << "step " << k << ": " << ws.message();
      finals.push_back(s.q);
    }
    for (std::size_t k = 1; k < finals.size(); ++k)
      EXPECT_LE((finals[k] - finals[0]).lpNorm<Eigen::Infinity>(), 1e-12) << to_string(rotation) << " scale " << k;
  }
}

// A body that would turn by more than the transform allows in one step: the step refuses with
// legendre-not-solved, names h |Omega|, and leaves the state as it was.
TEST(RigidStep, LegendreBeyondItsRangeIsRefusedWithTheStateUnchanged) {
  struct Case {
    Eigen::Matrix3d inertia;
    RotationLagrangian rotation;
    double h;
  };
  const Eigen::Matrix3d iso = Eigen::Matrix3d::Identity();
  const Eigen::Matrix3d aniso = Eigen::Vector3d(1.0, 2.0, 3.0).asDiagonal();
  for (const Case& c : {Case{iso, RotationLagrangian::MoserVeselov, 0.01}, Case{aniso, RotationLagrangian::MoserVeselov, 0.01},
                        Case{iso, RotationLagrangian::MoserVeselovF, 0.011}, Case{aniso, RotationLagrangian::Exponential, 0.011}}) {
    ModelBuilder b;
    RigidBody body;
    body.inertia = c.inertia;
    b.add_rigid_body(body);
    b.add_body_axis_constraint({0, Eigen::Vector3d::UnitX()});
    const Model model = b.build();
    Workspace ws(model);
    State s = start_from_velocity(model, ws, 0.0, Vector(Eigen::Vector4d(1, 0, 0, 0)), Vector(Eigen::Vector3d(0, 0, 150)));
    const State before = s;
    RattleOptions o = options(c.h, "auto", c.rotation);
    const Status status = step(model, ws, s, o);
    EXPECT_EQ(status, Status::LegendreNotSolved) << to_string(c.rotation);
    EXPECT_THAT(ws.message(), ::testing::HasSubstr("h |Omega| = 1."));
    EXPECT_THAT(ws.message(), ::testing::HasSubstr("rigid body 0"));
    EXPECT_TRUE(testing::bitwise_equal(s.q, before.q) && testing::bitwise_equal(s.p, before.p) &&
                testing::bitwise_equal(s.lambda, before.lambda) && s.t == before.t);
    // Just below its range the same body steps.
    o.h = 0.9 / 150.0;
    EXPECT_EQ(step(model, ws, s, o), Status::Ok) << to_string(c.rotation) << ": " << ws.message();
  }
  // From the command line: never status=ok.
  scenarios::RunConfig config;
  config.scene = "suslov";
  config.assignments = {"I11=1", "I22=1", "I33=1", "I13=0", "I23=0", "a1=1", "a3=0", "Omega3=150"};
  const auto summary = scenarios::run_scene(config);
  EXPECT_EQ(summary.status, Status::LegendreNotSolved);
  EXPECT_THAT(summary.message, ::testing::HasSubstr("h |Omega| = 1.5"));
}

// A rigid body with a planar centre, kept turning about the vertical (two body-axis rows) and
// carrying a knife edge written as a one-form in left-trivialised coordinates, against the
// planar sleigh: with the exponential Lagrangian the rotation about a principal axis by h Omega
// per step is the planar body's, and the two paths agree to round-off; Moser-Veselov turns by
// asin(h Omega) instead, an O(h^2) difference.
TEST(RigidStep, RigidBodyTurningAboutTheVerticalIsThePlanarSleigh) {
  const double m = 1.3, inertia = 0.7, a = 0.2;
  ModelBuilder pb;
  pb.add_planar_body({"x", "y", "theta"}, m, inertia);
  pb.add_knife_edge({0, a});
  const Model planar = pb.build();

  ModelBuilder rb;
  RigidBody body;
  body.mass = m;
  body.inertia = Eigen::Vector3d(2.0, 2.5, inertia).asDiagonal();  // physical: 0.7 + 2 >= 2.5
  body.translation = 2;
  rb.add_rigid_body(body);
  rb.add_one_form({0}, "Omega_x = 0");
  rb.add_one_form({1}, "Omega_y = 0");
  rb.add_one_form({2, 3, 4}, "knife edge");  // (Omega_z, xdot, ydot)
  // theta from a rotation about z: sin = 2 w z, cos = w^2 - z^2 (unit quaternion).
  rb.one_form_values([a](ConstVecRef q, VecRef mu) {
    const double w = q[0], z = q[3], n = w * w + z * z;
    mu << 1.0, 1.0, a, 2.0 * w * z / n, -(w * w - z * z) / n;
  });
  rb.one_form_bias([](ConstVecRef q, ConstVecRef v, VecRef bias) {
    const double w = q[0], z = q[3], n = w * w + z * z;
    const double s = 2.0 * w * z / n, c = (w * w - z * z) / n;
    bias[2] = v[2] * (c * v[3] + s * v[4]);
    bias[0] = bias[1] = 0.0;
  });
  const Model rigid = rb.build();

  const double th0 = 0.3, v0 = 1.0, w0 = 1.0;
  const Eigen::Vector3d qp(0.1, -0.2, th0), vp(v0 * std::cos(th0) - a * w0 * std::sin(th0),
                                                v0 * std::sin(th0) + a * w0 * std::cos(th0), w0);
  Vector qr(6), vr(5);
  qr << axis_angle_quaternion(Eigen::Vector3d::UnitZ(), th0), qp.head<2>();
  vr << 0.0, 0.0, w0, vp.head<2>();
  Workspace wp(planar), wr(rigid);
  for (RotationLagrangian rotation : {RotationLagrangian::Exponential, RotationLagrangian::MoserVeselov}) {
    State sp = start_from_velocity(planar, wp, 0.0, qp, vp), sr = start_from_velocity(rigid, wr, 0.0, qr, vr);
    const RattleOptions op = options(0.01), orr = options(0.01, "auto", rotation);
    double worst = 0.0;
    for (int k = 0; k < 1000; ++k) {
      ASSERT_EQ(step(planar, wp, sp, op), Status::Ok);
      ASSERT_EQ(step(rigid, wr, sr, orr), Status::Ok) << wr.message();
      const double theta = 2.0 * std::atan2(sr.q[3], sr.q[0]);
      const double dtheta = std::remainder(theta - sp.q[2], 2.0 * M_PI);
      worst = std::max({worst, std::abs(dtheta), (sr.q.segment<2>(4) - sp.q.head<2>()).cwiseAbs().maxCoeff(),
                        std::abs(sr.p[2] - sp.p[2]), (sr.p.segment<2>(3) - sp.p.head<2>()).cwiseAbs().maxCoeff()});
    }
    std::printf("rigid body turning about the vertical (%s) against the planar sleigh: %.3g over 1000 steps "
                "(restarts %ld and %ld)\n",
                to_string(rotation), worst, sr.restarts, sp.restarts);
    if (rotation == RotationLagrangian::Exponential) {
      EXPECT_LE(worst, 1e-13);
    } else {
      EXPECT_GT(worst, 1e-8);  // asin(h omega) against h omega per step
      EXPECT_LE(worst, 1e-4);
    }
  }
}

// R o Phi_h o R o Phi_h = id for the momentum flip R: 50 steps forward, p~ reversed, 50 more.
TEST(RigidStep, StepIsSymmetric) {
  for (const char* name : {"suslov", "chaplygin_ball", "ball_chain"}) {
    for (RotationLagrangian rotation :
         {RotationLagrangian::MoserVeselov, RotationLagrangian::MoserVeselovF, RotationLagrangian::Exponential}) {
      const auto setup = scene(name);
      Workspace ws(setup.model);
      State s = start_from_velocity(setup.model, ws, 0.0, setup.q0, setup.v0);
      const State start = s;
      const RattleOptions o = options(0.05, "0", rotation, HitchMode::OneForm);
      for (int k = 0; k < 50; ++k) ASSERT_EQ(step(setup.model, ws, s, o), Status::Ok) << ws.message();
      EXPECT_GT((s.q - start.q).norm(), 0.5);
      s.p = -s.p;
      for (int k = 0; k < 50; ++k) ASSERT_EQ(step(setup.model, ws, s, o), Status::Ok) << ws.message();
      s.p = -s.p;
      const double dq = (s.q - start.q).lpNorm<Eigen::Infinity>(), dp = (s.p - start.p).lpNorm<Eigen::Infinity>();
      const double dl = (s.lambda - start.lambda).lpNorm<Eigen::Infinity>();
      std::printf("%s (%s): back to the start within q %.2g, p %.2g, lambda %.2g\n", name, to_string(rotation), dq, dp,
                  dl);
      EXPECT_LE(dq, 1e-13);
      EXPECT_LE(dp, 1e-13);
      EXPECT_LE(dl, 1e-11);
    }
  }
}

// The start from (q0, q1): the first step lands on q1 (the discrete Legendre transform of the
// pair, for each Lagrangian); a turn no step can make (over 90 degrees) is refused.
TEST(RigidStep, TwoPointStartLandsOnTheSecondConfiguration) {
  const auto setup = scene("chaplygin_ball");
  const Model& model = setup.model;
  for (RotationLagrangian rotation :
       {RotationLagrangian::MoserVeselov, RotationLagrangian::MoserVeselovF, RotationLagrangian::Exponential}) {
    // q1 from one step of the method from lambda~_0 = 0, so that (q0, q1) lies in M0.
    Workspace ws(model);
    StartOptions zero;
    zero.multiplier = InitialMultiplier::Zero;
    State s = start_from_velocity(model, ws, 0.0, setup.q0, setup.v0, zero);
    const RattleOptions o = options(0.02, "0", rotation);
    State one = s;
    ASSERT_EQ(step(model, ws, one, o), Status::Ok);
    State two = start_from_two_points(model, ws, 0.0, s.q, one.q, 0.02, 1e-10, rotation);
    ASSERT_EQ(step(model, ws, two, o), Status::Ok);
    std::printf("two-point start (%s): first step lands %.2g from q1\n", to_string(rotation),
                (two.q - one.q).lpNorm<Eigen::Infinity>());
    EXPECT_LE((two.q - one.q).lpNorm<Eigen::Infinity>(), 1e-14) << to_string(rotation);
  }
  Workspace ws(model);
  Vector q1 = setup.q0;
  q1.head<4>() = axis_angle_quaternion(Eigen::Vector3d(0.2, 0.4, 1.0), 2.0);
  Vector q0 = setup.q0;
  q0.head<4>() << 1, 0, 0, 0;
  testing::expect_error([&] { start_from_two_points(model, ws, 0.0, q0, q1, 0.01); },
                        "rigid body 0 turns by 114.6 degrees from q0 to q1; a step turns a body by less than 90");
}

// Planar and rigid bodies in one model, a rigid body first (so the planar body's configuration
// and velocity entries sit at different offsets): each moves as it does alone, to the bit.
TEST(RigidStep, PlanarAndRigidBodiesInOneModel) {
  Eigen::Matrix3d inertia;
  inertia << 1, 0, .5, 0, 2, .5, .5, .5, 3;
  ModelBuilder both, alone_rigid, alone_planar;
  for (ModelBuilder* b : {&both, &alone_rigid}) {
    RigidBody body;
    body.inertia = inertia;
    body.any_inertia = true;  // the Suslov scene's test inertia (0.869 + 1.830 < 3.301)
    b->add_rigid_body(body);
    b->add_body_axis_constraint({0, Eigen::Vector3d::UnitZ()});
  }
  both.add_planar_body({"x", "y", "theta"}, 1.0, 1.0);
  both.add_knife_edge({1, 0.2});
  alone_planar.add_planar_body({"x", "y", "theta"}, 1.0, 1.0);
  alone_planar.add_knife_edge({0, 0.2});
  const Model m_both = both.build(), m_rigid = alone_rigid.build(), m_planar = alone_planar.build();
  EXPECT_EQ(m_both.num_configuration(), 7);
  EXPECT_EQ(m_both.num_velocities(), 6);
  EXPECT_EQ(m_both.body(1).q_offset, 4);
  EXPECT_EQ(m_both.body(1).offset, 3);
  EXPECT_EQ(m_both.coordinate_names()[4], "x");
  EXPECT_EQ(m_both.velocity_names()[0], "wx0");
  EXPECT_EQ(m_both.velocity_names()[3], "x");
  Vector q(7), v(6);
  q << 1, 0, 0, 0, 0.5, -0.5, 0.3;
  v << 1, 0.6, 0, 1.0, 0.2, 1.0;
  Workspace wb(m_both, {sparse::Backend::Dense}), wr(m_rigid, {sparse::Backend::Dense}), wp(m_planar, {sparse::Backend::Dense});
  State sb = start_from_velocity(m_both, wb, 0.0, q, v);
  State sr = start_from_velocity(m_rigid, wr, 0.0, q.head<4>(), v.head<3>());
  State sp = start_from_velocity(m_planar, wp, 0.0, q.tail<3>(), v.tail<3>());
  const RattleOptions o = options(0.01, "0");
  for (int k = 0; k < 500; ++k) {
    ASSERT_EQ(step(m_both, wb, sb, o), Status::Ok) << wb.message();
    ASSERT_EQ(step(m_rigid, wr, sr, o), Status::Ok);
    ASSERT_EQ(step(m_planar, wp, sp, o), Status::Ok);
  }
  const double dr = std::max((sb.q.head<4>() - sr.q).lpNorm<Eigen::Infinity>(), (sb.p.head<3>() - sr.p).lpNorm<Eigen::Infinity>());
  const double dp = std::max((sb.q.tail<3>() - sp.q).lpNorm<Eigen::Infinity>(), (sb.p.tail<3>() - sp.p).lpNorm<Eigen::Infinity>());
  std::printf("mixed model against each body alone, 500 steps: rigid %.2g, planar %.2g\n", dr, dp);
  EXPECT_LE(dr, 4 * kEps);  // C = diag: the same operations up to the dense solve's ordering
  EXPECT_LE(dp, 4 * kEps);
}

// A chain of balls on rods factorises C from its rows (ball_chain_band.cpp: no pattern, no Gram
// assembler). Against C = mu M^-1 mu^T made densely here from the model's own mu and M^-1: chains
// of 1, 2, 3 and 7 balls whose masses, radii, rod lengths and inertias (isotropic, or turned and
// non-diagonal) differ from ball to ball, at a turned, zigzag configuration; one rod given the
// other way round is no longer the layout (the general path, same answer). Then 50 steps on the
// band and on the dense backend.
TEST(RigidStep, BallChainBandIsTheGramOfItsRows) {
  for (int n : {1, 2, 3, 7})
    for (int variant : {0, 1, 2}) {
      SCOPED_TRACE("balls " + std::to_string(n) + ", variant " + std::to_string(variant));
      ModelBuilder b;
      for (int i = 0; i < n; ++i) {
        RigidBody body;
        body.mass = 1.0 + 0.3 * i;
        body.translation = 2;
        const Eigen::Matrix3d turn = Eigen::AngleAxisd(0.7 + 0.2 * i, Eigen::Vector3d(1.0, i, 2.0).normalized()).toRotationMatrix();
        body.inertia = variant == 0 ? Eigen::Matrix3d((0.4 + 0.05 * i) * Eigen::Matrix3d::Identity())
                                    : Eigen::Matrix3d((1.0 + 0.1 * i) * turn * Eigen::Vector3d(0.3, 0.4, 0.5).asDiagonal() * turn.transpose());
        b.add_rigid_body(body);
      }
      for (int i = 0; i < n; ++i) {
        b.add_rolling_ball({i, 0.8 + 0.1 * i});
        if (i + 1 < n) {
          const bool reversed = variant == 2 && i == n / 2;
          b.add_rod({reversed ? i + 1 : i, reversed ? i : i + 1, 2.5 + 0.2 * i});
        }
      }
      const Model m = b.build();
      const bool layout = !(variant == 2 && n >= 3);  // n = 2 has one rod, at i = 0: never reversed
      EXPECT_EQ(m.element_set()->ball_chain, layout);
      Vector q(6 * n), v(5 * n);
      for (int i = 0; i < n; ++i) {
        Eigen::Vector4d w(1.0, 0.3 * i - 0.5, 0.2, 0.1 * i);
        w.normalize();
        q.segment<6>(6 * i) << w, -2.7 * i, (i % 2 ? 0.9 : -0.4);
        v.segment<5>(5 * i) << 0.5 - 0.1 * i, 0.3, -0.2 + 0.05 * i, 0.1 * i, -0.3;
      }
      Workspace ws(m), dense(m, {sparse::Backend::Dense});
      if (layout) {
        ASSERT_NE(ws.banded(), nullptr);  // the band from the rows (auto picks it)
      }
      ASSERT_EQ(ws.factorize_at(q, 0.0), Status::Ok) << ws.message();
      // The reference, dense: mu from the model's values and pattern, W = M^-1 entry by entry.
      const sparse::RowPattern& pattern = m.one_form_pattern();
      Vector values(m.num_one_form_values()), by_rows(m.num_one_form_values());
      m.one_form_values(q, values);
      // The layout's own fill of mu (ElementSet::ball_chain_values) is each row's element, bit for bit.
      const detail::ElementSet& set = *m.element_set();
      for (std::size_t r = 0; r < set.num_rows(); ++r)
        detail::rigid_row_values(set, set.row(r), q.data(), by_rows.data() + set.value_start(r));
      EXPECT_TRUE(testing::bitwise_equal(values, by_rows));
      Vector gaps(m.num_holonomic()), gaps_by_rows(m.num_holonomic());  // and so are its rods' gaps
      if (m.num_holonomic() > 0) m.gap(q, gaps);
      for (std::size_t r = 0, j = 0; r < set.num_rows(); ++r)
        if (set.row(r).holonomic()) gaps_by_rows[static_cast<Eigen::Index>(j++)] = detail::rigid_row_gap(set, set.row(r), q.data());
      EXPECT_TRUE(testing::bitwise_equal(gaps, gaps_by_rows));
      Eigen::MatrixXd mu = Eigen::MatrixXd::Zero(m.num_one_forms(), m.num_velocities());
      for (int r = 0; r < pattern.rows; ++r)
        for (int k = pattern.row_ptr[r]; k < pattern.row_ptr[r + 1]; ++k) mu(r, pattern.col_idx[k]) = values[k];
      Eigen::MatrixXd w(m.num_velocities(), m.num_velocities());
      for (int i = 0; i < w.rows(); ++i)
        for (int j = 0; j < w.cols(); ++j) w(i, j) = m.inverse_mass().entry(i, j);
      const Eigen::MatrixXd c = mu * w * mu.transpose();
      Vector rhs(m.num_one_forms()), x(m.num_one_forms());
      for (int r = 0; r < rhs.size(); ++r) rhs[r] = std::cos(1.0 + 0.7 * r);
      ASSERT_EQ(ws.solve(rhs.data(), x.data()), Status::Ok);
      const Vector reference = c.ldlt().solve(rhs);
      EXPECT_LE((x - reference).lpNorm<Eigen::Infinity>(), 1e-13 * reference.lpNorm<Eigen::Infinity>());
      // mu x and mu^T y, by the layout ball by ball (ElementSet::ball_chain_times) or by the
      // pattern, are the dense products within the round-off of their sums: each sums at most four
      // products, within 3 u of the sum of their magnitudes (u = eps / 2), so the two within 6 u.
      Vector xv(m.num_velocities()), yv(m.num_one_forms()), mx(m.num_one_forms()), mty(m.num_velocities());
      for (int i = 0; i < xv.size(); ++i) xv[i] = std::sin(0.3 + 1.1 * i);
      for (int r = 0; r < yv.size(); ++r) yv[r] = std::cos(0.2 + 0.9 * r);
      mty.setConstant(NAN);  // every entry written
      m.mu_times(values.data(), xv.data(), mx.data());
      m.mu_transpose_times(values.data(), yv.data(), mty.data());
      const Vector mx_bound = mu.cwiseAbs() * xv.cwiseAbs(), mty_bound = mu.transpose().cwiseAbs() * yv.cwiseAbs();
      for (int r = 0; r < mx.size(); ++r) EXPECT_LE(std::abs(mx[r] - mu.row(r).dot(xv)), 6.7e-16 * mx_bound[r]) << "row " << r;
      for (int i = 0; i < mty.size(); ++i)
        EXPECT_LE(std::abs(mty[i] - mu.col(i).dot(yv)), 6.7e-16 * mty_bound[i]) << "velocity " << i;

      StartOptions open;  // the rods are not at their lengths here: the steps close them
      open.max_gap = std::numeric_limits<double>::infinity();
      State s = start_from_velocity(m, ws, 0.0, q, v, open), sd = start_from_velocity(m, dense, 0.0, q, v, open);
      const RattleOptions o = options(0.01, "0");
      for (int k = 0; k < 50; ++k) {
        ASSERT_EQ(step(m, ws, s, o), Status::Ok) << ws.message();
        ASSERT_EQ(step(m, dense, sd, o), Status::Ok) << dense.message();
      }
      EXPECT_LE((s.q - sd.q).lpNorm<Eigen::Infinity>(), 1e-12);
      EXPECT_LE((s.p - sd.p).lpNorm<Eigen::Infinity>(), 1e-12 * sd.p.lpNorm<Eigen::Infinity>());
    }
}

// The Suslov top written with a one-form callback on its Omega columns is the element model.
TEST(RigidStep, OneFormCallbackOnRigidBodyIsTheElement) {
  Eigen::Matrix3d inertia;
  inertia << 1, 0, .5, 0, 2, .5, .5, .5, 3;
  ModelBuilder element, callback;
  RigidBody body;
  body.inertia = inertia;
  body.any_inertia = true;  // the Suslov scene's test inertia (0.869 + 1.830 < 3.301)
  element.add_rigid_body(body);
  element.add_body_axis_constraint({0, Eigen::Vector3d::UnitZ()});
  callback.add_rigid_body(body);
  callback.add_one_form({0, 1, 2});
  callback.one_form_values([](ConstVecRef, VecRef mu) { mu << 0.0, 0.0, 1.0; });  // no bias given: differences
  const Model a = element.build(), b = callback.build();
  Workspace wa(a), wb(b);
  const Vector q0 = Eigen::Vector4d(1, 0, 0, 0), v0 = Eigen::Vector3d(1, 0.6, 0);
  State sa = start_from_velocity(a, wa, 0.0, q0, v0), sb = start_from_velocity(b, wb, 0.0, q0, v0);
  const RattleOptions o = options(0.01);
  for (int k = 0; k < 2000; ++k) {
    ASSERT_EQ(step(a, wa, sa, o), Status::Ok);
    ASSERT_EQ(step(b, wb, sb, o), Status::Ok);
  }
  // The bias by differences along q exp(+-d hat(Omega)) is exactly 0 here, as the element's.
  EXPECT_TRUE(testing::bitwise_equal(sa.q, sb.q) && testing::bitwise_equal(sa.p, sb.p));
  EXPECT_EQ(sa.restarts, sb.restarts);
}

// lambda~_0 = lambda_s (the continuous multiplier, with the gyroscopic term) against 0 on the
// Suslov top: the accurate start.
TEST(RigidStep, ContinuousMultiplierStartIsTheAccurateOne) {
  const auto setup = scene("suslov");
  double errors[2];
  int i = 0;
  for (InitialMultiplier start : {InitialMultiplier::Continuous, InitialMultiplier::Zero}) {
    Workspace ws(setup.model);
    StartOptions so;
    so.multiplier = start;
    State s = start_from_velocity(setup.model, ws, 0.0, setup.q0, setup.v0, so);
    const RattleOptions o = options(0.01, "0");
    for (int k = 0; k < 1000; ++k) ASSERT_EQ(step(setup.model, ws, s, o), Status::Ok);
    Workspace wf(setup.model);
    State fine = start_from_velocity(setup.model, wf, 0.0, setup.q0, setup.v0);
    const RattleOptions of = options(0.0005);
    for (int k = 0; k < 20000; ++k) ASSERT_EQ(step(setup.model, wf, fine, of), Status::Ok);
    errors[i++] = (s.q - fine.q).lpNorm<Eigen::Infinity>();
  }
  std::printf("Suslov, t = 10, h = 0.01: error with lambda~_0 = lambda_s %.3g, with 0 %.3g (%.1f times)\n", errors[0],
              errors[1], errors[1] / errors[0]);
  EXPECT_GT(errors[1] / errors[0], 20.0);
}

TEST(RigidStep, BuilderRefusesBadRigidBodiesAndElements) {
  using testing::expect_error;
  auto rigid = [](double m, Eigen::Matrix3d inertia, int d) {
    RigidBody b;
    b.mass = m;
    b.inertia = inertia;
    b.translation = d;
    return b;
  };
  const Eigen::Matrix3d id = Eigen::Matrix3d::Identity();
  Eigen::Matrix3d not_spd = id, not_symmetric = id, bad = id;
  not_spd(0, 1) = not_spd(1, 0) = 2.0;
  not_symmetric(0, 1) = 0.5;
  bad(2, 2) = std::nan("");
  expect_error([&] { ModelBuilder().add_rigid_body(rigid(1, id, 1)); }, "translation = 1 must be 0");
  expect_error([&] { ModelBuilder().add_rigid_body(rigid(-1, id, 2)); }, "mass m = -1 must be positive");
  expect_error([&] { ModelBuilder().add_rigid_body(rigid(1, not_spd, 0)); }, "inertia is not positive definite");
  expect_error([&] { ModelBuilder().add_rigid_body(rigid(1, not_symmetric, 0)); }, "inertia is not symmetric");
  expect_error([&] { ModelBuilder().add_rigid_body(rigid(1, bad, 0)); }, "inertia entry (2, 2) is nan");
  expect_error([&] { ModelBuilder().add_rigid_body(rigid(1e-13, id, 3)); }, "too ill-conditioned");
  // Physical inertias: each principal moment at most the sum of the other two, turned or not; a
  // flat plate (equality) is one, also when its moments come out of the eigensolver; 1:10:100 is
  // none, unless asked for.
  const Eigen::Matrix3d turn = Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  const Eigen::Matrix3d plate = turn * Eigen::Vector3d(1, 10, 11).asDiagonal() * turn.transpose();
  const Eigen::Matrix3d unphysical = turn * Eigen::Vector3d(1, 10, 100).asDiagonal() * turn.transpose();
  ModelBuilder().add_rigid_body(rigid(1, plate, 0));
  expect_error([&] { ModelBuilder().add_rigid_body(rigid(1, Eigen::Vector3d(100, 1, 10).asDiagonal().toDenseMatrix(), 0)); },
               "rigid body 0: principal moments 1, 10, 100 break the triangle inequality (1 + 10 < 100): no rigid "
               "body has them");
  expect_error([&] { ModelBuilder().add_rigid_body(rigid(1, unphysical, 2)); }, "break the triangle inequality");
  RigidBody on_purpose = rigid(1, unphysical, 2);
  on_purpose.any_inertia = true;
  ModelBuilder().add_rigid_body(on_purpose);
  ModelBuilder b;
  b.add_rigid_body(rigid(1, id, 0));
  b.add_rigid_body(rigid(1, id, 2));
  b.add_planar_body({"x", "y", "theta"}, 1, 1);
  expect_error([&] { b.add_rolling_ball({0, 1.0}); }, "has translation 0");
  expect_error([&] { b.add_rolling_disk({1, 1.0}); }, "has translation 2; a rolling disk");
  expect_error([&] { b.add_rolling_ball({1, -1.0}); }, "radius = -1 must be positive");
  expect_error([&] { b.add_body_axis_constraint({2, Eigen::Vector3d::UnitZ()}); }, "body 2 is not a 3-D rigid body");
  expect_error([&] { b.add_body_axis_constraint({0, Eigen::Vector3d::Zero()}); }, "must be finite and nonzero");
  expect_error([&] { b.add_knife_edge({0, 0.2}); }, "body 0 is a 3-D rigid body");
  expect_error([&] { b.add_rod({0, 1, 1.0}); }, "translation 0");
  expect_error([&] { b.add_rod({1, 7, 1.0}); }, "body 7 is out of range");
  b.add_rod({1, 2, 1.0});  // a rigid body's planar centre to a planar body's
  expect_error([&] { b.add_body_force({0, [](double) { return Eigen::Vector3d::Zero(); }}); }, "centre is fixed");
  ModelBuilder g;
  g.add_rigid_body(rigid(1, id, 2));
  g.add_gravity(9.81);
  expect_error([&] { g.build(); }, "gravity: no rigid body of the model moves in 3-D");
  // The start: a quaternion of the wrong norm, wrong sizes.
  ModelBuilder s;
  s.add_rigid_body(rigid(1, id, 0));
  const Model model = s.build();
  Workspace ws(model);
  expect_error([&] { start_from_velocity(model, ws, 0.0, Vector(Eigen::Vector4d(1, 1, 0, 0)), Vector::Zero(3)); },
               "the quaternion of rigid body 0 (qw0, qx0, qy0, qz0) has norm 1.414");
  expect_error([&] { start_from_velocity(model, ws, 0.0, Vector::Zero(3), Vector::Zero(3)); },
               "expected 4 entries in q0 (one per configuration entry), got 3");
  expect_error([&] { start_from_velocity(model, ws, 0.0, Vector(Eigen::Vector4d(1, 0, 0, 0)), Vector::Zero(4)); },
               "expected 3 entries in the velocity guess (one per velocity entry), got 4");
  // A symmetry generator must lie in D (checked at the start), and fill its entries.
  ModelBuilder sym;
  sym.add_rigid_body(rigid(1, id, 0));
  sym.add_body_axis_constraint({0, Eigen::Vector3d::UnitZ()});
  sym.symmetry("spin about a", [](ConstVecRef, VecRef xi) { xi << 0.0, 0.0, 1.0; });
  const Model m_sym = sym.build();
  Workspace w_sym(m_sym);
  expect_error([&] { start_from_velocity(m_sym, w_sym, 0.0, Vector(Eigen::Vector4d(1, 0, 0, 0)), Vector::Zero(3)); },
               "symmetry 'spin about a': its generator xi(q0) does not lie in D(q0): one-form row 0 gives mu xi = 1");
  ModelBuilder gap;
  gap.add_rigid_body(rigid(1, id, 0));
  gap.symmetry("lazy", [](ConstVecRef, VecRef xi) { xi[0] = 1.0; });
  const Model m_gap = gap.build();
  Workspace w_gap(m_gap);
  expect_error([&] { start_from_velocity(m_gap, w_gap, 0.0, Vector(Eigen::Vector4d(1, 0, 0, 0)), Vector::Zero(3)); },
               "symmetry 'lazy': its generator left entry 1 (wy0) unset or NaN at q0");
  // A local one (to its body): the body must exist; its entries are checked, and the rows that
  // reach them (body 1's axis row here, where its spin about x breaks it).
  ModelBuilder local;
  local.add_rigid_body(rigid(1, id, 0));
  expect_error([&] { local.symmetry("far", [](ConstVecRef, VecRef) {}, {}, 1); },
               "symmetry 'far': body 1 does not exist (the model has 1 bodies so far");
  local.add_rigid_body(rigid(1, id, 0));
  local.add_body_axis_constraint({1, Eigen::Vector3d::UnitX()});
  local.symmetry("spin of 1", [](ConstVecRef, VecRef xi) { xi.segment<3>(3) << 1.0, 0.0, 0.0; }, {}, 1);
  const Model m_local = local.build();
  Workspace w_local(m_local);
  Vector q2(8);
  q2 << 1, 0, 0, 0, 1, 0, 0, 0;
  expect_error([&] { start_from_velocity(m_local, w_local, 0.0, q2, Vector::Zero(6)); },
               "symmetry 'spin of 1': its generator xi(q0) does not lie in D(q0): one-form row 0 gives mu xi = 1");
  ModelBuilder local_gap;
  local_gap.add_rigid_body(rigid(1, id, 0));
  local_gap.add_rigid_body(rigid(1, id, 0));
  local_gap.symmetry("lazy local", [](ConstVecRef, VecRef xi) { xi[3] = 1.0; }, {}, 1);
  const Model m_local_gap = local_gap.build();
  Workspace w_local_gap(m_local_gap);
  expect_error([&] { start_from_velocity(m_local_gap, w_local_gap, 0.0, q2, Vector::Zero(6)); },
               "symmetry 'lazy local': its generator left entry 4 (wy1) unset or NaN at q0 (a local generator writes "
               "all of its body's entries)");
}

}  // namespace
}  // namespace nonholo
