// The implicit general form (docs/design.md section 2, first display) for a configuration-
// dependent metric: on the sleigh in contact-point coordinates (the paper's section 6) it is
// of order 2 against the exact solution and agrees with the explicit method on the
// centre-of-mass sleigh (the same physical system) to that order; with a constant metric it
// is the explicit RATTLE to round-off; a Newton failure leaves the state unchanged.
#include <nonholo/implicit.hpp>
#include <nonholo/model_builder.hpp>
#include <nonholo/rattle.hpp>
#include <nonholo/scenarios/exact_solutions.hpp>
#include <nonholo/scenarios/scene.hpp>
#include <nonholo/start.hpp>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <iostream>
#include <vector>

#include "support/scenes.hpp"
#include "support/expect_error.hpp"

namespace nonholo {
namespace {

using testing::scene;

// Centre-of-mass configuration (x_C, y_C, theta) every 0.5 time units to T = 10.
std::vector<Eigen::Vector3d> contact_run(double h) {
  const auto setup = scene("sleigh_contact");
  ImplicitWorkspace ws(setup.model);
  ImplicitOptions o;
  o.h = h;
  ImplicitState s = implicit_start(setup.model, ws, 0.0, setup.q0, setup.v0, o);
  std::vector<Eigen::Vector3d> out;
  const long steps = std::lround(10.0 / h), every = std::lround(0.5 / h);
  for (long k = 1; k <= steps; ++k) {
    EXPECT_EQ(implicit_step(setup.model, ws, s, o), Status::Ok) << ws.message();
    if (k % every == 0)
      out.emplace_back(s.q[0] + 0.2 * std::cos(s.q[2]), s.q[1] + 0.2 * std::sin(s.q[2]), s.q[2]);
  }
  return out;
}

std::vector<Eigen::Vector3d> centre_run(double h) {
  const auto setup = scene("sleigh");
  Workspace ws(setup.model);
  State s = start_from_velocity(setup.model, ws, 0.0, setup.q0, setup.v0);
  std::vector<Eigen::Vector3d> out;
  const long steps = std::lround(10.0 / h), every = std::lround(0.5 / h);
  for (long k = 1; k <= steps; ++k) {
    EXPECT_EQ(step(setup.model, ws, s, {h}), Status::Ok);
    if (k % every == 0) out.emplace_back(s.q);
  }
  return out;
}

double max_difference(const std::vector<Eigen::Vector3d>& a, const std::vector<Eigen::Vector3d>& b) {
  double worst = 0.0;
  for (std::size_t k = 0; k < a.size(); ++k) worst = std::max(worst, (a[k] - b[k]).lpNorm<Eigen::Infinity>());
  return worst;
}

TEST(Implicit, ContactSleighIsSecondOrderAndAgreesWithTheCentreSleigh) {
  const scenarios::SleighExact exact(1.0, 1.0, 0.2, 1.0, 1.0, 0.0, 0.0, 0.0);
  std::vector<Eigen::Vector3d> truth;
  for (int k = 1; k <= 20; ++k) truth.push_back(exact.configuration(0.5 * k));
  const auto c1 = contact_run(0.01), c2 = contact_run(0.005);
  const auto e1 = centre_run(0.01), e2 = centre_run(0.005);
  const double err1 = max_difference(c1, truth), err2 = max_difference(c2, truth);
  const double gap1 = max_difference(c1, e1), gap2 = max_difference(c2, e2);
  std::cout << "[implicit] sleigh_contact vs exact, T=10: " << err1 << " (h=0.01), " << err2
            << " (h=0.005), ratio " << err1 / err2 << "; vs explicit sleigh: " << gap1 << ", " << gap2
            << ", ratio " << gap1 / gap2 << "\n";
  EXPECT_NEAR(err1 / err2, 4.0, 0.4);
  EXPECT_LT(err1, 1e-3);
  EXPECT_NEAR(gap1 / gap2, 4.0, 0.4);
}

void add_drive(ModelBuilder& b);

// The centre-of-mass sleigh declared with a (constant) configuration metric, optionally
// driven (a force along the heading and a torque) and with a potential.
Model constant_metric_sleigh(bool driven) {
  ModelBuilder b;
  b.add_planar_body({"x", "y", "theta"}, 1.0, 1.0);
  b.configuration_metric([](ConstVecRef, MatRef m) { m = Eigen::Vector3d(1.0, 1.0, 1.0).asDiagonal(); },
                         [](ConstVecRef, int, MatRef dm) { dm.setZero(); });
  b.add_one_form({0, 1, 2});
  b.one_form_values([](ConstVecRef q, VecRef mu) { mu << std::sin(q[2]), -std::cos(q[2]), 0.2; });
  b.one_form_bias([](ConstVecRef q, ConstVecRef v, VecRef bias) {
    bias[0] = v[2] * (std::cos(q[2]) * v[0] + std::sin(q[2]) * v[1]);
  });
  if (driven) add_drive(b);
  return b.build();
}

void add_drive(ModelBuilder& b) {
  b.external_force([](double t, ConstVecRef q, VecRef f) {
    f << 0.3 * std::cos(q[2]), 0.3 * std::sin(q[2]), 0.2 * std::sin(2.0 * t);
  });
  b.potential([](ConstVecRef q) { return 0.05 * q[2] * q[2]; },
              [](ConstVecRef q, VecRef g) { g << 0.0, 0.0, 0.1 * q[2]; });
}

TEST(Implicit, WithAConstantMetricItIsTheExplicitMethod) {
  // The same step, start and restarts: driven or not, with every restart policy, the two
  // forms agree to round-off.
  for (bool driven : {false, true})
    for (const char* restart : {"0", "7", "auto"}) {
      const Model implicit_model = constant_metric_sleigh(driven);
      ModelBuilder e;
      e.add_planar_body({"x", "y", "theta"}, 1.0, 1.0);
      e.add_one_form({0, 1, 2});
      e.one_form_values([](ConstVecRef q, VecRef mu) { mu << std::sin(q[2]), -std::cos(q[2]), 0.2; });
      e.one_form_bias([](ConstVecRef q, ConstVecRef v, VecRef bias) {
        bias[0] = v[2] * (std::cos(q[2]) * v[0] + std::sin(q[2]) * v[1]);
      });
      if (driven) add_drive(e);
      const Model explicit_model = e.build();
      const auto setup = scene("sleigh");
      ImplicitWorkspace iws(implicit_model);
      ImplicitOptions o;
      set_restart(o.restart, restart);
      o.restart.tolerance = 1e-9;  // auto: restarts within these 1000 steps
      RattleOptions r{o.h};
      r.restart = o.restart;
      ImplicitState a = implicit_start(implicit_model, iws, 0.0, setup.q0, setup.v0, o);
      Workspace ws(explicit_model);
      State s = start_from_velocity(explicit_model, ws, 0.0, setup.q0, setup.v0);
      for (int k = 0; k < 1000; ++k) {
        ASSERT_EQ(implicit_step(implicit_model, iws, a, o), Status::Ok) << iws.message();
        ASSERT_EQ(step(explicit_model, ws, s, r), Status::Ok);
      }
      std::cout << "[implicit] constant metric, " << (driven ? "driven" : "free") << ", restart " << restart
                << ", 1000 steps: |q - q_rattle| = " << (a.q - s.q).lpNorm<Eigen::Infinity>() << ", restarts "
                << a.restarts << " and " << s.restarts << "\n";
      EXPECT_LE((a.q - s.q).lpNorm<Eigen::Infinity>(), 1e-12) << driven << " " << restart;
      EXPECT_EQ(a.restarts, s.restarts);
      if (std::string(restart) != "0") {
        EXPECT_GT(a.restarts, 0);
      }
    }
  // The explicit step refuses a configuration metric.
  const Model implicit_model = constant_metric_sleigh(false);
  Workspace wrong(implicit_model);
  const auto setup = scene("sleigh");
  Workspace ws(setup.model);
  State t = start_from_velocity(setup.model, ws, 0.0, setup.q0, setup.v0);
  EXPECT_EQ(step(implicit_model, wrong, t, {0.01}), Status::MethodNotApplicable);
}

// The implicit form has the explicit method's period-2 mode (docs/results/behaviour.md): on sleigh_contact with
// the plain method the energy of the average momentum collapses by t = 200; the default
// automatic restarts (measured against the continuous multiplier with the metric's
// Christoffel terms) keep it and the trajectory.
TEST(Implicit, RestartsKeepLongRunsRight) {
  const auto setup = scene("sleigh_contact");
  const scenarios::SleighExact exact(1.0, 1.0, 0.2, 1.0, 1.0, 0.0, 0.0, 0.0);
  double error[2], energy[2];
  long restarts[2];
  const char* policies[2] = {"auto", "0"};
  for (int i = 0; i < 2; ++i) {
    ImplicitWorkspace ws(setup.model);
    ImplicitOptions o;
    set_restart(o.restart, policies[i]);
    ImplicitState s = implicit_start(setup.model, ws, 0.0, setup.q0, setup.v0, o);
    Vector average(3), reflected(3);
    ASSERT_EQ(ws.reflect(s.q, s.p, average, reflected, 0.0), Status::Ok);
    const double e0 = ws.kinetic_energy(s.q, average);
    energy[i] = 0.0;
    for (int k = 0; k < 20000; ++k) {
      ASSERT_EQ(implicit_step(setup.model, ws, s, o), Status::Ok) << ws.message();
      ASSERT_EQ(ws.reflect(s.q, s.p, average, reflected, 0.0), Status::Ok);
      energy[i] = std::max(energy[i], std::abs(ws.kinetic_energy(s.q, average) - e0) / e0);
    }
    const Eigen::Vector2d centre(s.q[0] + 0.2 * std::cos(s.q[2]), s.q[1] + 0.2 * std::sin(s.q[2]));
    error[i] = std::max((centre - exact.positions({s.t}).back()).norm(), std::abs(s.q[2] - exact.heading(s.t)));
    restarts[i] = s.restarts;
  }
  std::cout << "[implicit] sleigh_contact to t = 200: automatic restarts (" << restarts[0] << "): error " << error[0]
            << ", energy of P* p+ " << energy[0] << "; plain: error " << error[1] << ", energy " << energy[1] << "\n";
  EXPECT_LE(energy[0], 1e-4);
  EXPECT_GT(energy[1], 0.5);
  EXPECT_LE(error[0], 1e-2);
  EXPECT_GT(error[1], 10 * error[0]);
}

TEST(Implicit, NewtonFailureLeavesTheStateUnchanged) {
  const auto setup = scene("sleigh_contact");
  ImplicitWorkspace ws(setup.model);
  ImplicitOptions o;
  o.h = 0.2;
  o.max_newton_iterations = 1;
  ImplicitState s = implicit_start(setup.model, ws, 0.0, setup.q0, setup.v0, o);
  const ImplicitState before = s;
  EXPECT_EQ(implicit_step(setup.model, ws, s, o), Status::NewtonNotConverged);
  EXPECT_THAT(ws.message(), ::testing::HasSubstr("Newton iterations"));
  EXPECT_EQ(s.q, before.q);
  EXPECT_EQ(s.p, before.p);
  EXPECT_EQ(s.t, before.t);
  o.max_newton_iterations = 30;
  EXPECT_EQ(implicit_step(setup.model, ws, s, o), Status::Ok) << ws.message();
  const auto sleigh = scene("sleigh");
  testing::expect_error([&] { ImplicitWorkspace w(sleigh.model); }, "needs a model with a configuration metric");
}

}  // namespace
}  // namespace nonholo
