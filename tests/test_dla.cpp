// The discrete Lagrange-d'Alembert baseline (docs/design.md section 2) against the exact sleigh and
// particle of section 6: the midpoint constraint gives order 2, the left-point one order 1
// and (the paper's observation) a far larger error; neither keeps the particle's energy,
// which the reflection method keeps exactly. Newton failures leave the state unchanged.
#include <nonholo/diagnostics.hpp>
#include <nonholo/dla.hpp>
#include <nonholo/rattle.hpp>
#include <nonholo/scenarios/exact_solutions.hpp>
#include <nonholo/scenarios/scene.hpp>
#include <nonholo/start.hpp>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <iostream>

#include "support/scenes.hpp"
#include "support/expect_error.hpp"

namespace nonholo {
namespace {

using testing::scene;

// A refused step leaves the state exactly as it was.
void expect_unchanged(const DlaState& s, const DlaState& before) {
  EXPECT_EQ(s.q, before.q);
  EXPECT_EQ(s.p, before.p);
  EXPECT_EQ(s.t, before.t);
}

// Max over the steps of |(x, y, theta) - exact| for the default sleigh to T.
double sleigh_error(DlaConstraint c, double h, double t_end) {
  const auto setup = scene("sleigh");
  const scenarios::SleighExact exact(1.0, 1.0, 0.2, 1.0, 1.0, 0.0, 0.0, 0.0);
  Workspace ws(setup.model);
  DlaOptions o;
  o.h = h;
  o.constraint = c;
  DlaState s = dla_start(start_from_velocity(setup.model, ws, 0.0, setup.q0, setup.v0), h);
  double err = 0.0;
  const long steps = std::lround(t_end / h);
  for (long k = 1; k <= steps; ++k) {
    EXPECT_EQ(dla_step(setup.model, ws, s, o), Status::Ok) << ws.message();
    if (k % std::lround(0.5 / h) == 0)
      err = std::max(err, (Eigen::Vector3d(s.q) - exact.configuration(s.t)).lpNorm<Eigen::Infinity>());
  }
  return err;
}

TEST(Dla, MidpointIsSecondOrderAndLeftPointFirstOrder) {
  const double mid1 = sleigh_error(DlaConstraint::Midpoint, 0.01, 10), mid2 = sleigh_error(DlaConstraint::Midpoint, 0.005, 10);
  const double left1 = sleigh_error(DlaConstraint::Left, 0.01, 10), left2 = sleigh_error(DlaConstraint::Left, 0.005, 10);
  std::cout << "[dla] sleigh T=10: midpoint " << mid1 << " / " << mid2 << " (ratio " << mid1 / mid2
            << "), left " << left1 << " / " << left2 << " (ratio " << left1 / left2
            << "), left / midpoint at h = 0.01: " << left1 / mid1 << "\n";
  EXPECT_NEAR(mid1 / mid2, 4.0, 0.4);
  EXPECT_NEAR(left1 / left2, 2.0, 0.2);
  EXPECT_GT(left1 / mid1, 10.0) << "the paper reports the left point 10 to 100 times worse";
}

TEST(Dla, ParticleEnergyDriftsWhereTheReflectionKeepsIt) {
  const auto setup = scene("particle");
  const double h = 0.05;
  Workspace ws(setup.model);
  const State start = start_from_velocity(setup.model, ws, 0.0, setup.q0, setup.v0);
  State ours = start;
  DlaState dla = dla_start(start, h);
  DlaOptions o;
  o.h = h;
  Vector scratch(3);
  const double e0 = kinetic_energy(setup.model, dla.p, scratch);
  const double post0 = kinetic_energy(setup.model, ours.pre_momentum(h), scratch);
  double dla_drift = 0.0, our_drift = 0.0;
  for (int k = 0; k < 400; ++k) {
    ASSERT_EQ(dla_step(setup.model, ws, dla, o), Status::Ok);
    ASSERT_EQ(step(setup.model, ws, ours, {h}), Status::Ok);
    dla_drift = std::max(dla_drift, std::abs(kinetic_energy(setup.model, dla.p, scratch) - e0) / e0);
    our_drift = std::max(our_drift, std::abs(kinetic_energy(setup.model, ours.pre_momentum(h), scratch) - post0) / post0);
  }
  std::cout << "[dla] particle, h = 0.05, T = 20: energy drift DLA midpoint " << dla_drift << ", reflection "
            << our_drift << "\n";
  EXPECT_GT(dla_drift, 1e-6);
  EXPECT_LT(our_drift, 1e-13);
}

TEST(Dla, NewtonFailureLeavesTheStateUnchanged) {
  const auto setup = scene("sleigh");
  Workspace ws(setup.model);
  DlaOptions o;
  o.h = 0.1;
  o.max_newton_iterations = 1;
  o.newton_tolerance = 1e-15;
  DlaState s = dla_start(start_from_velocity(setup.model, ws, 0.0, setup.q0, setup.v0), o.h);
  const DlaState before = s;
  EXPECT_EQ(dla_step(setup.model, ws, s, o), Status::NewtonNotConverged);
  EXPECT_THAT(ws.message(), ::testing::HasSubstr("midpoint constraints: relative residual"));
  expect_unchanged(s, before);
  DlaOptions bad;
  bad.max_newton_iterations = 0;
  testing::expect_error([&] { validate(bad); }, "max_newton_iterations = 0 must be at least 1");
}

// A workspace made without room for the midpoint's second copy of mu (dla_steps = false, as
// the CLI's reflection runs make it) refuses the midpoint step with a status and leaves the
// state; the left-point step, which needs no copy, runs and agrees with a full workspace.
TEST(Dla, LeanWorkspaceRefusesOnlyTheMidpointStep) {
  const auto setup = scene("sleigh");
  Workspace lean(setup.model, {sparse::Backend::Auto, false, false}), full(setup.model);
  EXPECT_EQ(lean.scratch_nnz.size(), 0);
  DlaOptions o;
  o.h = 0.05;
  DlaState s = dla_start(start_from_velocity(setup.model, lean, 0.0, setup.q0, setup.v0), o.h);
  const DlaState before = s;
  EXPECT_EQ(dla_step(setup.model, lean, s, o), Status::MethodNotApplicable);
  EXPECT_THAT(lean.message(), ::testing::HasSubstr("WorkspaceOptions::dla_steps = true"));
  expect_unchanged(s, before);
  o.constraint = DlaConstraint::Left;
  DlaState t = s;
  for (int k = 0; k < 10; ++k) {
    ASSERT_EQ(dla_step(setup.model, lean, s, o), Status::Ok) << lean.message();
    ASSERT_EQ(dla_step(setup.model, full, t, o), Status::Ok) << full.message();
  }
  EXPECT_EQ(s.q, t.q);
  EXPECT_EQ(s.p, t.p);
}

}  // namespace
}  // namespace nonholo
