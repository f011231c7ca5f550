// The explicit nonholonomic RATTLE step against a dense re-implementation, its defining
// identities (reflection, constraints preserved in average), and its failure contract:
// a status, the message, and the state left bit for bit as it was.
#include <nonholo/diagnostics.hpp>
#include <nonholo/model_builder.hpp>
#include <nonholo/rattle.hpp>
#include <nonholo/start.hpp>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "support/bitwise_equal.hpp"
#include "support/dense_reference.hpp"
#include "support/random_model.hpp"

namespace nonholo {
namespace {

using ::testing::HasSubstr;
using sparse::Backend;

double rel(const Vector& a, const Vector& b) { return (a - b).norm() / std::max(1.0, b.norm()); }

using testing::bitwise_equal;

bool bitwise_equal(const State& a, const State& b) {
  return a.t == b.t && bitwise_equal(a.q, b.q) && bitwise_equal(a.p, b.p) &&
         bitwise_equal(a.lambda, b.lambda) && bitwise_equal(a.force, b.force);
}

TEST(Rattle, MatchesDenseReferenceWithForcesOnEveryBackend) {
  for (std::uint32_t seed = 1; seed <= 12; ++seed) {
    testing::RandomModelOptions o;
    o.bodies = 5 + static_cast<int>(seed % 4);
    o.rows = 3 + static_cast<int>(seed % 4);
    o.applied_force = seed % 2 == 0;
    const Model model = testing::random_model(seed, o);
    const int n = model.num_coordinates();
    for (Backend backend : {Backend::Dense, Backend::CholmodAmd}) {
      Workspace ws(model, {backend});
      State s = start_from_velocity(model, ws, 0.3, testing::random_vector(seed, n, 0.5),
                                    testing::random_vector(seed + 7, n));
      State ref = s;
      const double h = 0.01;
      for (int k = 0; k < 50; ++k) {
        ASSERT_EQ(step(model, ws, s, {h}), Status::Ok) << ws.message();
        testing::dense_rattle_step(model, ref, h);
      }
      EXPECT_LE(rel(s.q, ref.q), 1e-12) << "seed " << seed << " " << ws.backend_name();
      EXPECT_LE(rel(s.p, ref.p), 1e-12) << "seed " << seed;
      EXPECT_LE(rel(s.lambda, ref.lambda), 1e-10) << "seed " << seed;
      EXPECT_LE(rel(s.force, ref.force), 1e-10) << "seed " << seed;
      EXPECT_DOUBLE_EQ(s.t, ref.t);
    }
  }
}

TEST(Rattle, PostMomentumIsTheReflectionOfThePreMomentum) {
  // f = 0: p_{k+1/2} = (P - Q)*_{q_k} p_{k-1/2}, with (P - Q)* built densely at q_k.
  const Model model = testing::random_model(3, {6, 4, false, true});
  Workspace ws(model);
  const int n = model.num_coordinates();
  State s = start_from_velocity(model, ws, 0.0, testing::random_vector(1, n), testing::random_vector(2, n));
  const double h = 0.02;
  for (int k = 0; k < 20; ++k) ASSERT_EQ(step(model, ws, s, {h}), Status::Ok);
  const Vector pre = s.pre_momentum(h), post = s.post_momentum(h);
  const Eigen::MatrixXd reflection = testing::dense_reflection(model, s.q);
  const double mismatch = rel(post, reflection * pre);
  EXPECT_LE(mismatch, 1e-13);
  // The reflection moves p by h mu^T lambda~, far more than the mismatch: the comparison
  // above would notice a missing or wrong reflection.
  EXPECT_GT(rel(post, pre), 1e6 * mismatch);
}

TEST(Rattle, ConstraintsArePreservedInAverage) {
  // mu(q_k)(q_{k+1} - q_{k-1}) = 0 (paper, equation (www2) for this Ld).
  const Model model = testing::random_model(5, {7, 5, false, true});
  Workspace ws(model);
  const int n = model.num_coordinates();
  State s = start_from_velocity(model, ws, 0.0, testing::random_vector(4, n), testing::random_vector(5, n));
  const double h = 0.01;
  Vector q_prev = s.q;
  ASSERT_EQ(step(model, ws, s, {h}), Status::Ok);
  for (int k = 0; k < 30; ++k) {
    const Vector q_mid = s.q;
    ASSERT_EQ(step(model, ws, s, {h}), Status::Ok);
    const Vector r = testing::dense_one_forms(model, q_mid) * (s.q - q_prev);
    EXPECT_LE(r.lpNorm<Eigen::Infinity>(), 1e-15 * (s.q - q_prev).norm() * 10);
    q_prev = q_mid;
  }
}

// A sleigh-like body whose second one-form collapses onto the first once x > 0.5, and whose
// rows turn NaN once y > 1: failures on demand.
Model fragile_model() {
  ModelBuilder b;
  b.add_planar_body({"x", "y", "theta"}, 1.0, 1.0);
  b.add_one_form({0, 1, 2});
  b.add_one_form({0, 1, 2});
  b.one_form_values([](ConstVecRef q, VecRef mu) {
    const double bad = q[1] > 1.0 ? NAN : 0.0;
    mu << 0.0, 0.0, 1.0 + bad, 0.0, q[0] > 0.5 ? 0.0 : 1.0, 1.0;
  });
  return b.build();
}

TEST(Rattle, FailedStepsLeaveTheStateUnchanged) {
  const Model model = fragile_model();
  for (Backend backend : {Backend::Dense, Backend::CholmodAmd}) {
    Workspace ws(model, {backend});
    // Allowed motion: xdot only (thetadot = 0 and ydot + thetadot = 0).
    State s = start_from_velocity(model, ws, 0.0, Vector::Zero(3), Eigen::Vector3d(1.0, 0.0, 0.0));
    for (int k = 0; k < 4; ++k) ASSERT_EQ(step(model, ws, s, {0.1}), Status::Ok) << ws.message();
    const State before = s;

    // x reaches 0.5 + 0.1: the rows become identical.
    Status status = step(model, ws, s, {0.2});
    EXPECT_TRUE(status == Status::DependentOneForms || status == Status::NearlyDependentOneForms)
        << to_string(status);
    EXPECT_THAT(ws.message(), HasSubstr("row"));
    // Every failure says what would fix it.
    EXPECT_THAT(ws.message(), status == Status::DependentOneForms ? HasSubstr("remove a redundant constraint")
                                                                   : HasSubstr("reduce the step size"));
    EXPECT_TRUE(bitwise_equal(s, before));

    EXPECT_EQ(step(model, ws, s, {-0.1}), Status::InvalidStepSize);
    EXPECT_THAT(ws.message(), HasSubstr("step size h = -0.1 must be positive and finite"));
    EXPECT_EQ(step(model, ws, s, {NAN}), Status::InvalidStepSize);
    EXPECT_TRUE(bitwise_equal(s, before));

    State wrong = s;
    wrong.lambda.resize(1);
    EXPECT_EQ(step(model, ws, wrong, {0.1}), Status::SizeMismatch);
    EXPECT_THAT(ws.message(), HasSubstr("lambda 1"));
    EXPECT_THAT(ws.message(), HasSubstr("create the state for this model"));

    const Model other = fragile_model();
    EXPECT_EQ(step(other, ws, s, {0.1}), Status::WorkspaceMismatch);
    EXPECT_THAT(ws.message(), HasSubstr("build one for this model"));
    EXPECT_TRUE(bitwise_equal(s, before));

    // The original step size still works afterwards.
    EXPECT_EQ(step(model, ws, s, {0.01}), Status::Ok);
  }
}

TEST(Rattle, NonFiniteOneFormsAndStatesAreRefused) {
  const Model model = fragile_model();
  Workspace ws(model);
  State s = start_from_velocity(model, ws, 0.0, Vector::Zero(3), Eigen::Vector3d(1.0, 0.0, 0.0));
  s.q[1] = 2.0;  // rows NaN at any q reached from here
  s.q[0] = -5.0;
  const State before = s;
  EXPECT_EQ(step(model, ws, s, {0.1}), Status::NonFiniteOneForms);
  EXPECT_THAT(ws.message(), HasSubstr("one-form row 0, column 2 (theta) has value nan: check the model"));
  EXPECT_TRUE(bitwise_equal(s, before));

  ModelBuilder b;
  b.add_body({"x"}, Eigen::Matrix<double, 1, 1>(1.0));
  b.external_force([](double t, ConstVecRef, VecRef f) { f[0] = t > 0.55 ? INFINITY : 0.0; });
  const Model exploding = b.build();
  Workspace ws2(exploding);
  State e = start_from_velocity(exploding, ws2, 0.0, Vector::Zero(1), Vector::Ones(1));
  for (int k = 0; k < 5; ++k) ASSERT_EQ(step(exploding, ws2, e, {0.1}), Status::Ok);
  const State kept = e;
  EXPECT_EQ(step(exploding, ws2, e, {0.1}), Status::NonFiniteState);
  EXPECT_THAT(ws2.message(), HasSubstr("produced NaN or Inf: reduce the step size (h = 0.1)"));
  EXPECT_TRUE(bitwise_equal(e, kept));
}

TEST(Rattle, UnconstrainedModelIsVelocityVerlet) {
  // No one-forms and a harmonic potential: the scheme is velocity Verlet, whose energy
  // error is O(h^2) and bounded; compare with the closed form x(t) = cos t to O(h^2).
  ModelBuilder b;
  b.add_body({"x"}, Eigen::Matrix<double, 1, 1>(1.0));
  b.potential([](ConstVecRef q) { return 0.5 * q[0] * q[0]; },
              [](ConstVecRef q, VecRef g) { g[0] = q[0]; });
  const Model model = b.build();
  Workspace ws(model);
  EXPECT_STREQ(ws.backend_name(), "none");
  State s = start_from_velocity(model, ws, 0.0, Vector::Ones(1), Vector::Zero(1));
  const double h = 0.01;
  double err = 0.0;
  for (int k = 0; k < 1000; ++k) {
    ASSERT_EQ(step(model, ws, s, {h}), Status::Ok);
    err = std::max(err, std::abs(s.q[0] - std::cos(s.t)));
  }
  EXPECT_LT(err, 1e-4);
  EXPECT_GT(err, 1e-7);
}

TEST(Rattle, OptionsValidation) {
  EXPECT_THROW(validate(RattleOptions{0.0}), std::invalid_argument);
  EXPECT_THROW(validate(RattleOptions{0.01, -1.0}), std::invalid_argument);
  try {
    validate(RattleOptions{-2.0});
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr("step size h = -2 must be positive and finite"));
  }
  EXPECT_NO_THROW(validate(RattleOptions{0.01}));
}

TEST(Diagnostics, MatchDirectFormulas) {
  const Model model = testing::random_model(11, {5, 3, true, true});
  Workspace ws(model);
  const int n = model.num_coordinates();
  State s = start_from_velocity(model, ws, 0.0, testing::random_vector(1, n), testing::random_vector(2, n));
  const double h = 0.05;
  State prev = s;
  for (int k = 0; k < 10; ++k) {
    prev = s;
    ASSERT_EQ(step(model, ws, s, {h}), Status::Ok);
  }
  const Eigen::MatrixXd minv = testing::dense_mass(model).inverse();
  const Diagnostics d = diagnose(model, ws, s, h);
  EXPECT_NEAR(d.energy, 0.5 * s.p.dot(minv * s.p) + model.potential(s.q), 1e-13);
  // The post-momentum of the last step, reconstructed from the previous state.
  const Vector p_post = prev.post_momentum(h);
  EXPECT_NEAR(d.energy_post,
              0.5 * p_post.dot(minv * p_post) + 0.5 * (model.potential(prev.q) + model.potential(s.q)),
              1e-12);
  EXPECT_NEAR(d.residual, (testing::dense_one_forms(model, s.q) * minv * s.p).lpNorm<Eigen::Infinity>(), 1e-15);
  EXPECT_LE(d.residual, 1e-14);
}

}  // namespace
}  // namespace nonholo
