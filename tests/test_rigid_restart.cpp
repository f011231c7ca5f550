// Restarts of 3-D bodies keep the post-momentum energy and the momentum maps (docs/design.md
// section 10.3): where the maps see all of p~ (a Chaplygin ball) the restart turns lambda~
// towards lambda_s on the ellipsoid E_post fixes; on Suslov, Veselova and a chain of Chaplygin
// balls it rescales the part of p~ the maps do not see. Anisotropic and non-diagonal inertias,
// restarts every 100 steps and the default ones, 10^5 steps each.
#include <nonholo/diagnostics.hpp>
#include <nonholo/model_builder.hpp>
#include <nonholo/rattle.hpp>
#include <nonholo/restart.hpp>
#include <nonholo/scenarios/scene.hpp>
#include <nonholo/start.hpp>

#include "scenes/rigid/ball_symmetries.hpp"  // the scene's generators (nonholo_private_headers)
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

// The ball chain's model built by hand, its spins declared local to their balls (as the scene
// does) or over all of p (`order`: 0 spins local, 1 spins over all of p, 2 the rollings first and
// the spins local after them).
Model ball_chain_model(int n, int order) {
  using scenarios::BallSlots;
  RigidBody body;
  body.inertia = Eigen::Vector3d(0.3, 0.4, 0.5).asDiagonal();
  body.translation = 2;
  ModelBuilder b;
  std::vector<BallSlots> slots;
  for (int i = 0; i < n; ++i) {
    b.add_rigid_body(body);
    slots.push_back({6 * i, 5 * i});
  }
  for (int i = 0; i < n; ++i) {
    b.add_rolling_ball({i, 1.0});
    if (i + 1 < n) b.add_rod({i, i + 1, 3.0});
  }
  auto rollings = [&] {
    b.symmetry("roll_x", scenarios::rolling(slots, 1.0, 0));
    b.symmetry("roll_y", scenarios::rolling(slots, 1.0, 1));
  };
  if (order == 2) rollings();
  for (int i = 0; i < n; ++i) {
    auto local = scenarios::vertical_spin(slots[i]);
    if (order == 1)
      b.symmetry("spin" + std::to_string(i), [local](ConstVecRef q, VecRef xi) {
        xi.setZero();
        local(q, xi);
      });
    else
      b.symmetry("spin" + std::to_string(i), local, scenarios::vertical_spin_value(slots[i]), i);
  }
  if (order != 2) rollings();
  return std::move(b).build();
}

// Local spins are stored in their balls' entries only (15 N doubles for N spins and two rollings,
// against (N + 2) 5 N), and the restarts they give are those of the same spins declared over
// all of p, to the bit; declared after the rollings (which then widen every spin's slot) they
// keep the maps as well.
TEST(RigidRestart, LocalSymmetriesAreStoredByTheirBodyAndRestartAsWholeOnesDo) {
  const int n = 10;
  const auto scene_setup = scene("ball_chain", {"bodies=10", "I1=0.3", "I3=0.5", "symmetries=0"});
  State end[3];
  long pool[3];
  double maps[3];
  for (int order : {0, 1, 2}) {
    const Model model = ball_chain_model(n, order);
    Workspace ws(model);
    pool[order] = ws.map_pool.size();
    State s = start_from_velocity(model, ws, 0.0, scene_setup.q0, scene_setup.v0);
    RattleOptions o = options(0.01, "auto", HitchMode::OneForm);
    o.restart.tolerance = 1e-300;  // a restart at every step
    o.restart.monitor_every = 1;
    Vector j0(model.momentum_maps().size()), j(j0.size());
    evaluate_momentum_maps(model, s, j0);
    maps[order] = 0.0;
    for (int k = 0; k < 300; ++k) {
      ASSERT_EQ(step(model, ws, s, o), Status::Ok) << ws.message();
      evaluate_momentum_maps(model, s, j);
      maps[order] = std::max(maps[order], (j - j0).lpNorm<Eigen::Infinity>() / j0.lpNorm<Eigen::Infinity>());
    }
    EXPECT_EQ(s.restarts, 300);
    end[order] = s;
  }
  std::printf("10-ball chain, a restart at every step for 300 steps: pools of %ld (spins local), %ld (spins over all "
              "of p), %ld (rollings first) doubles; maps kept to %.3g, %.3g, %.3g of their size\n",
              pool[0], pool[1], pool[2], maps[0], maps[1], maps[2]);
  EXPECT_EQ(pool[0], 15 * n);
  EXPECT_EQ(pool[1], (n + 2) * 5 * n);
  EXPECT_TRUE(testing::bitwise_equal(end[0].q, end[1].q) && testing::bitwise_equal(end[0].p, end[1].p) &&
              testing::bitwise_equal(end[0].lambda, end[1].lambda));
  for (double m : maps) EXPECT_LE(m, 1e-12);
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
