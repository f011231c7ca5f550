// Restarts of 3-D bodies keep the post-momentum energy and the momentum maps (docs/design.md
// section 10.3): where the maps see all of p~ (a Chaplygin ball) the restart turns lambda~
// towards lambda_s on the ellipsoid E_post fixes; on Suslov, Veselova and a chain of Chaplygin
// balls it rescales the part of p~ the maps do not see. Anisotropic and non-diagonal inertias,
// restarts every 100 steps and the default ones, 10^5 steps each.
#include <nonholo/diagnostics.hpp>
#include <nonholo/rattle.hpp>
#include <nonholo/restart.hpp>
#include <nonholo/scenarios/scene.hpp>
#include <nonholo/start.hpp>

#include "support/bitwise_equal.hpp"
#include "support/rigid_watch.hpp"
#include "support/scenes.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <complex>
#include <limits>
#include <cstdio>

namespace nonholo {
namespace {

using testing::scene;

constexpr double kEps = std::numeric_limits<double>::epsilon();

RattleOptions options(double h, const char* restart, HitchMode hitch = HitchMode::Holonomic) {
  RattleOptions o;
  o.h = h;
  o.hitch = hitch;
  set_restart(o.restart, restart);
  return o;
}

TEST(RigidRestart, EveryBodyShapeKeepsItsPostMomentumEnergyAndMapsThroughRestarts) {
  for (const char* name : {"chaplygin_ball", "suslov", "veselova"}) {
    for (const auto& shape : testing::body_shapes()) {
      const auto setup = scene(name, testing::inertia_sets(shape.inertia));
      for (const char* restart : {"100", "auto"}) {
        const testing::Watch w = testing::watch(setup, options(0.01, restart), 100000);
        std::printf("%s, %s, restart %s, 1e5 steps of 0.01: %ld restarts, E_post %.3g, maps %.3g of their size, "
                    "|mu M^-1 p~| %.3g\n",
                    name, shape.name, restart, w.restarts, w.energy_post, w.maps_rel, w.residual);
        EXPECT_LE(w.energy_post, 1e-12) << name << ", " << shape.name << ", restart " << restart;
        EXPECT_LE(w.maps_rel, 1e-12) << name << ", " << shape.name << ", restart " << restart;
        EXPECT_LE(w.residual, 1e-13) << name << ", " << shape.name << ", restart " << restart;
        if (std::string(restart) == "100") {
          EXPECT_EQ(w.restarts, 1000);
        }
      }
    }
  }
}

TEST(RigidRestart, ChainOfChaplyginBallsKeepsItsPostMomentumEnergyAndMaps) {
  // Rods as one-forms: position-level rods do work of their own (holonomic mode).
  const auto setup = scene("ball_chain", {"bodies=10", "I1=0.3", "I3=0.5"});
  for (const char* restart : {"100", "auto"}) {
    const testing::Watch w = testing::watch(setup, options(0.01, restart, HitchMode::OneForm), 100000);
    std::printf("10 Chaplygin balls on rods, restart %s, 1e5 steps: %ld restarts, E_post %.3g, maps %.3g of their size\n",
                restart, w.restarts, w.energy_post, w.maps_rel);
    EXPECT_LE(w.energy_post, 1e-12) << restart;
    EXPECT_LE(w.maps_rel, 1e-12) << restart;
  }
}

// |mu^T x|^2_{M^-1} = x^T C x, and x^T C y, at the workspace's mu.
double c_dot(const Model& model, const Workspace& ws, const Vector& x, const Vector& y) {
  Vector mx(model.num_velocities()), my(model.num_velocities()), v(model.num_velocities());
  model.mu_transpose_times(ws.mu_values.data(), x.data(), mx.data());
  model.mu_transpose_times(ws.mu_values.data(), y.data(), my.data());
  model.inverse_mass().multiply(my.data(), v.data());
  return mx.dot(v);
}

// The closed form on a single ball: p~ is fixed by K, so E_post = (1/2)|p~|^2 + (h^2/8)|lambda~|_C^2
// fixes |lambda~|_C and the restart gives lambda_s scaled to that norm. A lambda~ turned away
// from lambda_s (a mode) and lengthened by 10 % comes back as 1.1 lambda_s, p~ to the bit.
TEST(RigidRestart, OnAChaplyginBallTheRestartTurnsLambdaOntoLambdaS) {
  const auto setup = scene("chaplygin_ball", testing::inertia_sets(testing::body_shapes()[0].inertia));
  const Model& model = setup.model;
  ASSERT_EQ(model.num_one_forms(), 2);
  Workspace ws(model);
  State s = start_from_velocity(model, ws, setup.t0, setup.q0, setup.v0);
  const RattleOptions o = options(0.01, "100");
  for (int k = 0; k < 50; ++k) ASSERT_EQ(step(model, ws, s, o), Status::Ok) << ws.message();
  ASSERT_EQ(restart(model, ws, s, o), Status::Ok) << ws.message();  // lambda~ on lambda_s's ray
  ASSERT_EQ(ws.evaluate_one_forms(s.q), Status::Ok);
  const Vector lambda_s = s.lambda;  // up to the scale s^2 = 1 + O(h^2): the direction is lambda_s's
  Vector across(2);  // C-orthogonal to lambda_s, of the same C-norm
  across << -c_dot(model, ws, lambda_s, Vector::Unit(2, 1)), c_dot(model, ws, lambda_s, Vector::Unit(2, 0));
  across *= std::sqrt(c_dot(model, ws, lambda_s, lambda_s) / c_dot(model, ws, across, across));
  ASSERT_NEAR(c_dot(model, ws, across, lambda_s), 0.0, 1e-12 * c_dot(model, ws, lambda_s, lambda_s));
  const double turn = 0.3;
  s.lambda = 1.1 * (std::cos(turn) * lambda_s + std::sin(turn) * across);
  model.mu_transpose_times(ws.mu_values.data(), s.lambda.data(), s.force.data());
  const Vector p = s.p;
  const double e = diagnose(model, ws, s, o.h).energy_post;
  double before = 0.0, after = 0.0;
  ASSERT_EQ(parasitic_amplitude(model, ws, s, o.h, before), Status::Ok);
  ASSERT_EQ(restart(model, ws, s, o), Status::Ok) << ws.message();
  ASSERT_EQ(parasitic_amplitude(model, ws, s, o.h, after), Status::Ok);
  const double e_after = diagnose(model, ws, s, o.h).energy_post;
  // The energy equation sees lambda~ through (h^2/8)|lambda~|_C^2, so the scale is as exact as
  // E_post's round-off over that term; the amplitude left is the lengthening's, 0.1 of |lambda_s|_C
  // where the turned one was |1.1 e^{0.3 i} - 1| of it.
  const double lambda_term = o.h * o.h / 8.0 * c_dot(model, ws, s.lambda, s.lambda);
  const double scale_error = (s.lambda - 1.1 * lambda_s).norm() / (1.1 * lambda_s.norm());
  const double expected = before * 0.1 / std::abs(1.1 * std::polar(1.0, turn) - 1.0);
  std::printf("ball: lambda~ turned by 0.3 and lengthened by 10 %%: amplitude %.4g -> %.4g (expected %.4g), "
              "|lambda~ - 1.1 lambda_s| %.3g (E_post's round-off over the lambda term: %.3g), E_post change %.3g\n",
              before, after, expected, scale_error, kEps * e / lambda_term, std::abs(e_after - e) / e);
  EXPECT_TRUE(testing::bitwise_equal(s.p, p));
  EXPECT_LE(scale_error, 16.0 * kEps * e / lambda_term);
  EXPECT_LE(std::abs(e_after - e), 4.0 * kEps * e);
  // (Its denominators, |p_-|^2 + (h/2)^2 |mu^T lambda~|^2, differ by O(h^2) = 1e-4 of them.)
  EXPECT_NEAR(after, expected, 1e-3 * expected);
}

}  // namespace
}  // namespace nonholo
