// Adaptive composed steps (adaptive.hpp): the error reached against the tolerance on the exact
// sleigh and on a 10-body chain against a tight reference, rejected pairs and shadow steps that
// leave no trace, landing on the stop time, and the refusals.
#include <nonholo/adaptive.hpp>
#include <nonholo/rattle.hpp>
#include <nonholo/scenarios/exact_solutions.hpp>

#include "support/bitwise_equal.hpp"
#include "support/driven_particle.hpp"
#include "support/expect_error.hpp"
#include "support/scenes.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <iostream>
#include <limits>
#include <string>

namespace nonholo {
namespace {

using testing::scene;

struct Outcome {
  State state;
  long accepted, rejected;
};

Outcome run_to(const scenarios::SceneSetup& setup, int order, double tol, double T, HitchMode hitch = HitchMode::OneForm) {
  RattleOptions o;
  o.order = order;
  o.hitch = hitch;
  AdaptiveOptions a;
  a.tol = tol;
  a.horizon = T - setup.t0;
  AdaptiveStepper stepper(setup.model, o, a);
  Workspace ws(setup.model, {sparse::Backend::Auto, true});
  State s = start_from_velocity(setup.model, ws, setup.t0, setup.q0, setup.v0);
  while (s.t < T) {
    const Status status = stepper.step(setup.model, ws, s, T);
    EXPECT_EQ(status, Status::Ok) << ws.message();
    if (status != Status::Ok) break;
  }
  EXPECT_EQ(s.t, T) << "the last step lands on T exactly";
  return {s, stepper.accepted(), stepper.rejected()};
}

// The error at the end over the tolerance (docs/guide/methods.md "Adaptive steps" lists each): sleigh (t = 10,
// exact) order 2: 4.3-4.4 (1e-4 ... 1e-9), orders 4, 6, 8: 1.8-3.0, 0.44-2.6, 0.42-1.7 (1e-4
// ... 1e-11); 10-body chain (t = 100, against ARKODE at 1e-15) order 2: 0.22-0.23 (1e-4 ...
// 1e-6), order 4: 0.57-0.89, order 6: 0.095-0.53, order 8: 0.016-0.44 (1e-4 ... 1e-11). The
// budget is the sum of the local errors; what stays below 0.1 is the symmetric compositions'
// errors cancelling along the chain's motion (order 8 most), which costs steps ((1 / 0.016)^(1/8)
// = 1.7 times more than needed at most) but never accuracy. Below 1e-9 (order 2 on the sleigh)
// the tolerance asks for local errors below round-off: the steps settle at the floor, 2.4e-9.
// A tenfold miss either way fails (order 8 on the chain: a hundredfold below).
TEST(Adaptive, TheErrorFollowsTheTolerance) {
  const auto sleigh = scene("sleigh");
  const scenarios::SleighExact ex(1.0, 1.0, 0.2, 1.0, 1.0, 0.0, 0.0, 0.0);
  const Vector exact = ex.configuration(10.0);
  const auto chain = scene("sleigh_chain", {"bodies=10"});
  const Vector reference = testing::reference_at(chain, 100.0, 1e-15);
  struct Case {
    const char* label;
    const scenarios::SceneSetup& setup;
    const Vector& truth;
    double T;
    int order;
    double tightest;
    double low;  // the lowest error / tol allowed
  };
  for (const Case& c : {Case{"sleigh", sleigh, exact, 10.0, 2, 1e-9, 0.1}, Case{"sleigh", sleigh, exact, 10.0, 4, 1e-11, 0.1},
                        Case{"sleigh", sleigh, exact, 10.0, 6, 1e-11, 0.1}, Case{"sleigh", sleigh, exact, 10.0, 8, 1e-11, 0.1},
                        Case{"chain", chain, reference, 100.0, 2, 1e-6, 0.1}, Case{"chain", chain, reference, 100.0, 4, 1e-11, 0.1},
                        Case{"chain", chain, reference, 100.0, 6, 1e-11, 0.05},
                        Case{"chain", chain, reference, 100.0, 8, 1e-11, 0.01}}) {
    for (double tol = 1e-4; tol >= c.tightest * 0.99; tol /= 10.0) {
      const Outcome out = run_to(c.setup, c.order, tol, c.T);
      const double error = (out.state.q - c.truth).lpNorm<Eigen::Infinity>();
      std::cout << c.label << " order " << c.order << " tol " << tol << ": error " << error << " (" << error / tol
                << " tol), " << out.accepted << " steps, " << out.rejected << " pairs rejected\n";
      EXPECT_GT(error / tol, c.low) << c.label << " order " << c.order << " tol " << tol;
      EXPECT_LT(error / tol, 10.0) << c.label << " order " << c.order << " tol " << tol;
    }
  }
}

// Every accepted pair is two composed steps of its size from the state it started at: the
// rejected attempts and the shadow step left nothing behind (state, and nothing the step reads
// from the workspace). Checked against a fresh workspace stepping from a copy, bit for bit.
TEST(Adaptive, RejectedAttemptsLeaveNoTrace) {
  const auto setup = scene("sleigh_chain", {"bodies=5"});
  for (HitchMode hitch : {HitchMode::OneForm, HitchMode::Holonomic}) {
    RattleOptions o;
    o.order = 6;
    o.hitch = hitch;
    AdaptiveOptions a;
    a.tol = 1e-10;
    a.h_initial = 0.3;  // too long for 1e-10: the first pairs are rejected
    AdaptiveStepper stepper(setup.model, o, a);
    Workspace ws(setup.model, {sparse::Backend::Auto, true});
    State s = start_from_velocity(setup.model, ws, setup.t0, setup.q0, setup.v0);
    for (int k = 0; k < 30; ++k) {
      const State before = s;
      ASSERT_EQ(stepper.step(setup.model, ws, s, 50.0), Status::Ok) << ws.message();
      Workspace fresh(setup.model, {sparse::Backend::Auto, true});
      State again = before;
      RattleOptions one = o;
      one.h = stepper.last_step();
      for (int i = 0; i < 2; ++i) ASSERT_EQ(step(setup.model, fresh, again, one), Status::Ok) << fresh.message();
      EXPECT_EQ(again.t, s.t);
      EXPECT_TRUE(testing::bitwise_equal(again.q, s.q)) << to_string(hitch) << " step " << k;
      EXPECT_TRUE(testing::bitwise_equal(again.p, s.p)) << to_string(hitch) << " step " << k;
      EXPECT_TRUE(testing::bitwise_equal(again.lambda, s.lambda)) << to_string(hitch) << " step " << k;
    }
    EXPECT_GT(stepper.rejected(), 0) << to_string(hitch);
  }
}

TEST(Adaptive, RefusesWhatItCannotDo) {
  const auto setup = scene("sleigh");
  RattleOptions o;
  o.order = 3;
  testing::expect_error([&] { AdaptiveStepper(setup.model, o, {}); }, "adaptive steps: order = 3 must be 2, 4, 6 or 8");
  o.order = 6;
  AdaptiveOptions a;
  a.tol = 0.0;
  testing::expect_error([&] { AdaptiveStepper(setup.model, o, a); }, "AdaptiveOptions: tol = 0 must lie in (0, 1)");
  a = {};
  a.h_min = 1.0;
  testing::expect_error([&] { AdaptiveStepper(setup.model, o, a); }, "h_min = 1 must be positive and at most h_initial");
  a = {};
  a.max_factor = 1.0;
  testing::expect_error([&] { AdaptiveStepper(setup.model, o, a); }, "max_factor = 1 must be above 1");
  // A stop time not after the state's: a status, the state untouched.
  AdaptiveStepper stepper(setup.model, o, {});
  Workspace ws(setup.model, {sparse::Backend::Auto, true});
  State s = start_from_velocity(setup.model, ws, setup.t0, setup.q0, setup.v0);
  const State before = s;
  EXPECT_EQ(stepper.step(setup.model, ws, s, s.t), Status::InvalidStepSize);
  EXPECT_THAT(std::string(ws.message()), ::testing::HasSubstr("is not after t = 0"));
  EXPECT_TRUE(testing::bitwise_equal(before.q, s.q));
  EXPECT_EQ(stepper.accepted() + stepper.rejected(), 0);
}

// A composed step that keeps failing (a force that turns NaN at t = 0.5): the stepper retries
// 4 times smaller down to h_min, then returns StepSizeTooSmall with the state as it was.
TEST(Adaptive, GivesUpBelowTheSmallestStepWithTheStateAsItWas) {
  const Model model = testing::driven_particle([](double t, ConstVecRef, VecRef f) {
    f.setZero();
    f[1] = t > 0.5 ? std::numeric_limits<double>::quiet_NaN() : std::sin(t);
  });
  RattleOptions o;
  o.order = 4;
  AdaptiveOptions a;
  a.h_initial = 0.05;
  a.h_min = 1e-6;
  AdaptiveStepper stepper(model, o, a);
  Workspace ws(model, {sparse::Backend::Auto, true});
  State s = start_from_velocity(model, ws, 0.0, Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(1, 1, 0));
  Status status = Status::Ok;
  State before = s;
  for (int k = 0; k < 100 && status == Status::Ok; ++k) {
    before = s;
    status = stepper.step(model, ws, s, 10.0);
  }
  EXPECT_EQ(status, Status::StepSizeTooSmall);
  EXPECT_THAT(std::string(ws.message()), ::testing::HasSubstr("below h_min = 1e-06 (the last attempt: non-finite"));
  EXPECT_LE(s.t, 0.5);
  EXPECT_GT(s.t, 0.5 - 1e-5);
  EXPECT_TRUE(testing::bitwise_equal(before.q, s.q));
  EXPECT_TRUE(testing::bitwise_equal(before.p, s.p));
  EXPECT_EQ(before.t, s.t);
}

}  // namespace
}  // namespace nonholo
