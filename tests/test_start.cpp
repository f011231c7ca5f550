// Consistent starts: the M-orthogonal projection and the continuous multiplier against
// dense formulas, the paper's start from (q0, q1) in M0, and the set-up errors.
#include <nonholo/dynamics.hpp>
#include <nonholo/model_builder.hpp>
#include <nonholo/rattle.hpp>
#include <nonholo/start.hpp>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "support/dense_reference.hpp"
#include "support/expect_error.hpp"
#include "support/random_model.hpp"

namespace nonholo {
namespace {

using ::testing::HasSubstr;

TEST(Start, ProjectsTheVelocityGuessAndSetsTheContinuousMultiplier) {
  for (std::uint32_t seed = 1; seed <= 8; ++seed) {
    const Model model = testing::random_model(seed, {6, 4, seed % 2 == 1, true});
    Workspace ws(model);
    const int n = model.num_coordinates();
    const Vector q0 = testing::random_vector(seed + 1, n), v = testing::random_vector(seed + 2, n);
    const State s = start_from_velocity(model, ws, 0.7, q0, v);
    const Eigen::MatrixXd mass = testing::dense_mass(model);
    const Vector p_expected = testing::dense_project(model, q0, mass * v);
    EXPECT_LE((s.p - p_expected).norm(), 1e-13 * p_expected.norm());
    EXPECT_LE((testing::dense_one_forms(model, q0) * mass.inverse() * s.p).lpNorm<Eigen::Infinity>(), 1e-14);
    const Vector qdot = mass.inverse() * s.p;
    const Vector lambda = testing::dense_multiplier(model, 0.7, q0, qdot);
    EXPECT_LE((s.lambda - lambda).norm(), 1e-12 * std::max(1.0, lambda.norm()));
    const Vector force = testing::dense_applied_force(model, 0.7, q0) +
                         testing::dense_one_forms(model, q0).transpose() * lambda;
    EXPECT_LE((s.force - force).norm(), 1e-12 * std::max(1.0, force.norm()));
    EXPECT_EQ(s.t, 0.7);
  }
}

TEST(Start, ZeroMultiplierOption) {
  const Model model = testing::random_model(2, {5, 3, true, true});
  Workspace ws(model);
  const int n = model.num_coordinates();
  StartOptions o;
  o.multiplier = InitialMultiplier::Zero;
  const State s = start_from_velocity(model, ws, 0.0, testing::random_vector(1, n), testing::random_vector(2, n), o);
  EXPECT_EQ(s.lambda.norm(), 0.0);
  EXPECT_LE((s.force - testing::dense_applied_force(model, 0.0, s.q)).norm(), 1e-15);
}

TEST(Start, FiniteDifferenceBiasMatchesTheAnalyticOne) {
  for (std::uint32_t seed = 1; seed <= 6; ++seed) {
    const Model analytic = testing::random_model(seed, {6, 4, false, true});
    const Model numeric = testing::random_model(seed, {6, 4, false, false});
    ASSERT_FALSE(numeric.has_analytic_bias());
    Workspace wa(analytic), wn(numeric);
    const int n = analytic.num_coordinates();
    const Vector q = testing::random_vector(seed + 3, n), v = testing::random_vector(seed + 4, n);
    Vector ba(4), bn(4);
    ASSERT_EQ(one_form_bias(analytic, wa, q, v, ba), Status::Ok);
    ASSERT_EQ(one_form_bias(numeric, wn, q, v, bn), Status::Ok);
    // Central difference with step cbrt(eps): error ~ eps^(2/3) ~ 4e-11 of the terms' size.
    EXPECT_LE((ba - bn).lpNorm<Eigen::Infinity>(), 1e-9 * std::max(1.0, ba.lpNorm<Eigen::Infinity>()))
        << "seed " << seed;
  }
}

TEST(Start, FromTwoPointsInM0LandsOnQ1AndMatchesTheZeroMultiplierStart) {
  const Model model = testing::random_model(4, {6, 4, true, true});
  const int n = model.num_coordinates();
  Workspace ws(model);
  StartOptions zero;
  zero.multiplier = InitialMultiplier::Zero;
  const double h = 0.01;
  State a = start_from_velocity(model, ws, 0.0, testing::random_vector(1, n), testing::random_vector(2, n), zero);
  // q1 reached from a consistent (q0, p~_0, 0) is in M0 by construction.
  const Vector q1 = a.q + h * testing::dense_mass(model).inverse() * a.post_momentum(h);
  State b = start_from_two_points(model, ws, 0.0, a.q, q1, h);
  EXPECT_LE((b.p - a.p).norm(), 1e-12 * a.p.norm());
  EXPECT_EQ(b.lambda.norm(), 0.0);
  ASSERT_EQ(step(model, ws, b, {h}), Status::Ok);
  EXPECT_LE((b.q - q1).norm(), 1e-14 * q1.norm());
  ASSERT_EQ(step(model, ws, a, {h}), Status::Ok);
  for (int k = 0; k < 100; ++k) {
    ASSERT_EQ(step(model, ws, a, {h}), Status::Ok);
    ASSERT_EQ(step(model, ws, b, {h}), Status::Ok);
  }
  EXPECT_LE((a.q - b.q).norm(), 1e-11 * a.q.norm());
}

TEST(Start, FromTwoPointsOutsideM0IsRefused) {
  const Model model = testing::random_model(4, {6, 4, false, true});
  const int n = model.num_coordinates();
  Workspace ws(model);
  const Vector q0 = testing::random_vector(1, n);
  try {
    start_from_two_points(model, ws, 0.0, q0, q0 + 0.01 * testing::random_vector(9, n), 0.01);
    FAIL() << "no exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr("start: (q0, q1) is not in M0: one-form row 0 gives mu(q0) M^-1 p0 = "));
  }
  EXPECT_THROW(start_from_two_points(model, ws, 0.0, q0, q0, 0.0), std::invalid_argument);
}

TEST(Start, BadInputIsReported) {
  const Model model = testing::random_model(4, {3, 2, false, true});
  const int n = model.num_coordinates();
  Workspace ws(model);
  const auto expect = testing::expect_error<std::exception>;
  const Vector ok = Vector::Zero(n), short_q = Vector::Zero(n - 1);
  expect([&] { start_from_velocity(model, ws, 0.0, short_q, ok); },
         "start: expected " + std::to_string(n) + " entries in q0 (one per coordinate), got " + std::to_string(n - 1));
  expect([&] { start_from_velocity(model, ws, 0.0, ok, short_q); }, "entries in the velocity guess");
  Vector nan_q = ok;
  nan_q[1] = NAN;
  expect([&] { start_from_velocity(model, ws, 0.0, nan_q, ok); }, "start: q0[1] (" + model.coordinate_names()[1] + ") is nan");
  expect([&] { start_from_velocity(model, ws, INFINITY, ok, ok); }, "initial time t0 = inf is not finite");

  // One-forms that are dependent at q0: std::invalid_argument (the documented set-up error),
  // naming the row eliminated last by its label.
  ModelBuilder b;
  b.add_planar_body({"x", "y", "theta"}, 1.0, 1.0);
  b.add_one_form({0, 1}, "the original");
  b.add_one_form({0, 1}, "the copy");
  b.one_form_values([](ConstVecRef q, VecRef mu) { mu << 1.0, q[2], 1.0, 0.0; });
  const Model dependent = b.build();
  Workspace wd(dependent);
  try {
    start_from_velocity(dependent, wd, 0.0, Vector::Zero(3), Vector::Ones(3));
    FAIL() << "no exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr("projecting the velocity onto D(q0)"));
    EXPECT_THAT(e.what(), HasSubstr("dependent"));
    EXPECT_THAT(e.what(), HasSubstr("(row 1 is the copy)"));
  }
  EXPECT_NO_THROW(start_from_velocity(dependent, wd, 0.0, Eigen::Vector3d(0, 0, 1), Vector::Ones(3)));
}

}  // namespace
}  // namespace nonholo
