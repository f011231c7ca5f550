// The chain scenes (docs/design.md sections 4 and 5): their one-forms against the geometry they
// encode, the pattern of C at angles that zero some of its values, the single-body chain
// against the sleigh, the hitch gap in holonomic mode, the post-momentum energy in one-form
// mode, the generated train, and the holonomic iteration's failure path.
#include <nonholo/diagnostics.hpp>
#include <nonholo/rattle.hpp>
#include <nonholo/scenarios/scene.hpp>
#include <nonholo/start.hpp>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <iostream>
#include <limits>
#include <string>
#include <vector>

#include "support/dense_reference.hpp"
#include "support/expect_error.hpp"
#include "support/random_model.hpp"

namespace nonholo {
namespace {

scenarios::SceneSetup chain(const std::string& name, const std::vector<std::string>& sets) {
  const auto& info = scenarios::find_scene(name);
  auto p = info.defaults();
  for (const auto& s : sets) p.assign(s);
  return info.build(p);
}

Vector random_configuration(const scenarios::SceneSetup& setup, std::uint32_t seed) {
  return setup.q0 + testing::random_vector(seed, static_cast<int>(setup.q0.size()), 0.7);
}

// Blade rows: mu_i qdot is minus the blade's sideways velocity, (B_i)' . (-sin, cos) with
// B_i = C_i - a e(theta_i). Hitch rows: the gradient of the gap, whose value is the rear
// hitch of i minus the front hitch of i+1 (both computed here from the geometry).
TEST(Chain, OneFormsAreTheGeometryTheyEncode) {
  const double m = 1.0, I = 1.0, a = 0.2, d = 0.5, f = 0.5;
  const auto setup = chain("sleigh_chain", {"bodies=5"});
  const Model& model = setup.model;
  const int n = model.num_coordinates(), bodies = 5;
  ASSERT_EQ(model.num_one_forms(), 5 + 2 * 4);
  ASSERT_EQ(model.num_holonomic(), 8);
  (void)m;
  (void)I;
  for (std::uint32_t seed = 1; seed <= 5; ++seed) {
    const Vector q = random_configuration(setup, seed), v = testing::random_vector(seed + 50, n);
    const Eigen::MatrixXd mu = testing::dense_one_forms(model, q);
    const Vector muv = mu * v;
    Vector gap(model.num_holonomic());
    model.gap(q, gap);
    for (int i = 0; i < bodies; ++i) {
      const double th = q[3 * i + 2], w = v[3 * i + 2];
      const Eigen::Vector2d blade_velocity(v[3 * i] + a * std::sin(th) * w, v[3 * i + 1] - a * std::cos(th) * w);
      const double sideways = blade_velocity.dot(Eigen::Vector2d(-std::sin(th), std::cos(th)));
      EXPECT_NEAR(muv[3 * i], -sideways, 1e-14) << "blade " << i;
      if (i + 1 == bodies) continue;
      const double th1 = q[3 * i + 5];
      const Eigen::Vector2d rear = q.segment<2>(3 * i) - d * Eigen::Vector2d(std::cos(th), std::sin(th));
      const Eigen::Vector2d front = q.segment<2>(3 * i + 3) + f * Eigen::Vector2d(std::cos(th1), std::sin(th1));
      EXPECT_NEAR(gap[2 * i], (rear - front).x(), 1e-14);
      EXPECT_NEAR(gap[2 * i + 1], (rear - front).y(), 1e-14);
    }
    // Hitch rows = d gap / dq by central differences.
    const auto& rows = model.holonomic_rows();
    for (int j = 0; j < n; ++j) {
      const double hstep = 1e-6;
      Vector qp = q, qm = q, gp(gap.size()), gm(gap.size());
      qp[j] += hstep;
      qm[j] -= hstep;
      model.gap(qp, gp);
      model.gap(qm, gm);
      for (int r = 0; r < model.num_holonomic(); ++r)
        EXPECT_NEAR(mu(rows[r], j), (gp[r] - gm[r]) / (2 * hstep), 1e-9) << "row " << rows[r] << " col " << j;
    }
  }
}

TEST(Chain, AnalyticBiasMatchesTheDerivativeOfTheOneForms) {
  for (const char* name : {"sleigh_chain", "wheeled_train"}) {
    const auto setup = chain(name, {"bodies=6"});
    const Model& model = setup.model;
    const int n = model.num_coordinates();
    const Vector q = random_configuration(setup, 3), v = testing::random_vector(4, n);
    Vector bias(model.num_one_forms());
    model.analytic_bias(q, v, bias);
    const double e = 1e-4;  // 4-point difference of mu(q + s v) v at s = 0: error O(e^4)
    auto mu_v = [&](double s) -> Vector { return testing::dense_one_forms(model, q + s * v) * v; };
    const Vector fd = (8.0 * (mu_v(e) - mu_v(-e)) - (mu_v(2 * e) - mu_v(-2 * e))) / (12.0 * e);
    EXPECT_LE((bias - fd).lpNorm<Eigen::Infinity>(), 1e-9) << name;
  }
}

// The pattern of C is fixed when the model is built; at theta = 0 several of its values are
// exactly zero (blade i against hitch i: sin(theta)/m + a d sin(theta)/I) and keep their
// slots. Counted independently: per body a blade diagonal; per hitch two diagonals, their
// coupling and four blade couplings; per pair of neighbouring hitches four couplings.
TEST(Chain, PatternOfCIsFixedAndKeepsSlotsThatVanish) {
  const int bodies = 10;
  const auto setup = chain("sleigh_chain", {"bodies=10"});
  const Model& model = setup.model;
  const auto& pattern = model.gram().pattern();
  EXPECT_EQ(pattern.nnz(), bodies + 7 * (bodies - 1) + 4 * (bodies - 2));
  auto lower_of = [&](const Vector& q) {
    Vector mu(model.num_one_form_values()), c(pattern.nnz());
    model.one_form_values(q, mu);
    model.gram().assemble(mu.data(), c.data());
    Eigen::MatrixXd dense = Eigen::MatrixXd::Zero(pattern.size, pattern.size);
    for (int j = 0; j < pattern.size; ++j)
      for (int s = pattern.col_ptr[j]; s < pattern.col_ptr[j + 1]; ++s) dense(pattern.row_idx[s], j) = c[s];
    return std::make_pair(c, dense);
  };
  for (std::uint32_t seed : {0u, 1u, 2u}) {
    const Vector q = seed == 0 ? setup.q0 : random_configuration(setup, seed);
    const auto [c, lower] = lower_of(q);
    const Eigen::MatrixXd mu = testing::dense_one_forms(model, q);
    const Eigen::MatrixXd exact = mu * testing::dense_mass(model).inverse() * mu.transpose();
    const Eigen::MatrixXd exact_lower = exact.triangularView<Eigen::Lower>();
    EXPECT_LE((lower - exact_lower).cwiseAbs().maxCoeff(), 1e-14) << "no entry of C outside its slots";
    const long zeros = (c.array() == 0.0).count();
    if (seed == 0) {
      EXPECT_GE(zeros, 2 * (bodies - 1)) << "at theta = 0 the blade-hitch couplings vanish, slots kept";
    } else {
      EXPECT_EQ(zeros, 0);
    }
  }
  // A run through theta = 0 (the lead turns one way, then the other) keeps every step ok on
  // the banded path; the pattern object is the model's and never changes.
  Workspace ws(model);
  State s = start_from_velocity(model, ws, 0.0, setup.q0, setup.v0);
  const int nnz = pattern.nnz();
  for (int k = 0; k < 500; ++k) ASSERT_EQ(step(model, ws, s, {0.01}), Status::Ok) << ws.message();
  EXPECT_EQ(model.gram().pattern().nnz(), nnz);
}

TEST(Chain, SingleBodyChainIsTheSleigh) {
  const auto one = chain("sleigh_chain", {"bodies=1", "omega0=1"});
  const auto sleigh = chain("sleigh", {});
  Workspace wa(one.model), wb(sleigh.model);
  State a = start_from_velocity(one.model, wa, 0.0, one.q0, one.v0);
  State b = start_from_velocity(sleigh.model, wb, 0.0, sleigh.q0, sleigh.v0);
  for (int k = 0; k < 1000; ++k) {
    ASSERT_EQ(step(one.model, wa, a, {0.01}), Status::Ok);
    ASSERT_EQ(step(sleigh.model, wb, b, {0.01}), Status::Ok);
  }
  EXPECT_LE((a.q - b.q).lpNorm<Eigen::Infinity>(), 1e-14);
  EXPECT_LE((a.p - b.p).lpNorm<Eigen::Infinity>(), 1e-14);
}

struct RunStats {
  double gap_max = 0.0, energy_post_change = 0.0, energy_change = 0.0;
  int max_iterations = 0;
};

RunStats simulate(const scenarios::SceneSetup& setup, HitchMode mode, long steps, double h,
                  const char* restart = "auto") {
  const Model& model = setup.model;
  Workspace ws(model);
  State s = start_from_velocity(model, ws, 0.0, setup.q0, setup.v0);
  RattleOptions o;
  o.h = h;
  o.hitch = mode;
  set_restart(o.restart, restart);
  const Diagnostics d0 = diagnose(model, ws, s, h);
  RunStats r;
  for (long k = 0; k < steps; ++k) {
    const Status status = step(model, ws, s, o);
    EXPECT_EQ(status, Status::Ok) << ws.message();
    if (status != Status::Ok) break;
    r.max_iterations = std::max(r.max_iterations, ws.gap_iterations);
    const Diagnostics d = diagnose(model, ws, s, h);
    r.gap_max = std::max(r.gap_max, d.gap);
    r.energy_post_change = std::max(r.energy_post_change, std::abs(d.energy_post - d0.energy_post) / d0.energy_post);
    r.energy_change = std::max(r.energy_change, std::abs(d.energy - d0.energy) / d0.energy);
  }
  return r;
}

// Holonomic mode holds the hitches to round-off over 10^4 steps; one-form mode lets the gap
// drift (so the test can tell the modes apart).
TEST(Chain, HolonomicModeKeepsTheHitchGapBelow1e10) {
  const auto setup = chain("sleigh_chain", {"bodies=10"});
  const RunStats holo = simulate(setup, HitchMode::Holonomic, 10000, 0.01);
  const RunStats loose = simulate(setup, HitchMode::OneForm, 10000, 0.01);
  std::cout << "[chain gap] sleigh_chain 10 bodies, 10^4 steps of 0.01: holonomic max |g| " << holo.gap_max
            << " (at most " << holo.max_iterations << " corrections per step), one-form max |g| "
            << loose.gap_max << "\n";
  EXPECT_LE(holo.gap_max, 1e-10);
  EXPECT_GT(loose.gap_max, 1e-8);

  const auto train = chain("wheeled_train", {"bodies=100"});
  const RunStats driven = simulate(train, HitchMode::Holonomic, 10000, 0.01);
  std::cout << "[chain gap] wheeled_train 100 bodies, 10^4 steps (automatic restarts): holonomic max |g| "
            << driven.gap_max
            << " (at most " << driven.max_iterations << " corrections per step)\n";
  EXPECT_LE(driven.gap_max, 1e-10);
}

// One-form mode with f = 0 is the paper's reflection: the post-momentum energy is exact up
// to round-off. Bound: each step adds a few eps of relative error (docs/design.md: round-off),
// so 10^4 steps stay below 10^4 * 8 eps = 1.8e-11; holonomic mode's position correction is
// not a reflection, and its energy moves far more (checked so that the bound means
// something).
TEST(Chain, OneFormModePreservesThePostMomentumEnergy) {
  const auto setup = chain("sleigh_chain", {"bodies=10"});
  const RunStats oneform = simulate(setup, HitchMode::OneForm, 10000, 0.01);
  const RunStats holo = simulate(setup, HitchMode::Holonomic, 10000, 0.01);
  const double eps = std::numeric_limits<double>::epsilon();
  std::cout << "[chain energy] sleigh_chain 10 bodies, 10^4 steps, f = 0: post-momentum energy change "
            << oneform.energy_post_change << " one-form, " << holo.energy_post_change
            << " holonomic; energy of p~ " << oneform.energy_change << "\n";
  EXPECT_LE(oneform.energy_post_change, 1e4 * 8 * eps);
  EXPECT_GT(holo.energy_post_change, 100 * oneform.energy_post_change);
}

TEST(Chain, GeneratedTrainIsReproducibleAndWithinItsRanges) {
  auto masses = [](const scenarios::SceneSetup& s) {
    Vector out(s.model.num_bodies());
    for (int b = 0; b < s.model.num_bodies(); ++b) out[b] = s.model.mass().diagonal()[s.model.body(b).offset];
    return out;
  };
  const auto a = chain("wheeled_train", {"bodies=200", "seed=7"});
  const auto b = chain("wheeled_train", {"bodies=200", "seed=7"});
  const auto c = chain("wheeled_train", {"bodies=200", "seed=8"});
  EXPECT_EQ(masses(a), masses(b));
  EXPECT_NE(masses(a), masses(c));
  const Vector m = masses(a);
  EXPECT_GE(m.minCoeff(), 0.75);
  EXPECT_LE(m.maxCoeff(), 1.25);
  EXPECT_GT(m.maxCoeff() - m.minCoeff(), 0.4) << "spread 0.25 is used";
  // Blade offsets a_i and hitch lengths d_i, f_{i+1} read off the one-forms at theta = pi/2.
  const Model& model = a.model;
  Vector q = a.q0;
  for (int i = 0; i < model.num_bodies(); ++i) q[3 * i + 2] = M_PI / 2;
  Vector mu(model.num_one_form_values());
  model.one_form_values(q, mu);
  for (int i = 0; i + 1 < model.num_bodies(); ++i) {
    const double blade = mu[11 * i + 2], d = mu[11 * i + 4], f = mu[11 * i + 6];
    EXPECT_TRUE(blade >= 0.15 && blade <= 0.25) << blade;
    EXPECT_TRUE(d >= 0.375 && d <= 0.625) << d;
    EXPECT_TRUE(f >= 0.375 && f <= 0.625) << f;
  }
  // The lead is driven: force N (force + ...) along its heading, torque N steer sin(...).
  const auto& info = scenarios::find_scene("wheeled_train");
  const auto p = info.defaults();
  Vector force(model.num_coordinates()), scratch(model.num_coordinates());
  model.applied_force(1.0, q, force, scratch);
  EXPECT_NEAR(force[0], 0.0, 1e-12);
  EXPECT_NEAR(force[1], 200 * p["force"], 1e-12);  // heading pi/2: along +y
  EXPECT_NEAR(force[2], 200 * p["steer"] * std::sin(p["steer_omega"]), 1e-12);
  EXPECT_EQ(force.tail(model.num_coordinates() - 3).cwiseAbs().maxCoeff(), 0.0);
}

TEST(Chain, BadParametersAreRejectedClearly) {
  testing::expect_error([] { chain("sleigh_chain", {"bodies=0"}); },
                        "sleigh_chain: parameter bodies = 0 must be a whole number from 1 to 10000000");
  testing::expect_error([] { chain("sleigh_chain", {"bodies=2.5"}); }, "must be a whole number");
  testing::expect_error([] { chain("sleigh_chain", {"hitched=2"}); },
                        "parameter hitched = 2 must be a whole number from 0 to 1");
  testing::expect_error([] { chain("sleigh_chain", {"d=0"}); }, "parameter d = 0 must be positive");
  testing::expect_error([] { chain("wheeled_train", {"spread=1.5"}); },
                        "wheeled_train: parameter spread = 1.5 must lie in [0, 0.9]");
  testing::expect_error([] { chain("wheeled_train", {"seed=-1"}); }, "parameter seed = -1 must be a whole number");
}

// Holonomic mode's iteration: too few corrections for a badly opened hitch returns
// GapNotConverged and leaves the state exactly as it was; bad options are refused.
TEST(Chain, GapIterationFailureLeavesTheStateUnchanged) {
  const auto setup = chain("sleigh_chain", {"bodies=4"});
  const Model& model = setup.model;
  Workspace ws(model);
  Vector q0 = setup.q0;
  q0[3] += 1e-3;  // body 1 pulled off its hitch
  testing::expect_error([&] { start_from_velocity(model, ws, 0.0, q0, setup.v0); },
                        "a holonomic row is open at q0: one-form row 1 (the hitch with rear body 0 and front body 1, "
                        "its x row) has gap");
  StartOptions open;
  open.max_gap = std::numeric_limits<double>::infinity();  // the step closes it
  State s = start_from_velocity(model, ws, 0.0, q0, setup.v0, open);
  const State before = s;
  RattleOptions o;
  o.max_gap_iterations = 1;
  EXPECT_EQ(step(model, ws, s, o), Status::GapNotConverged);
  EXPECT_THAT(ws.message(), ::testing::HasSubstr("hitch gap"));
  EXPECT_THAT(ws.message(), ::testing::HasSubstr("after 1 corrections"));
  EXPECT_EQ(s.q, before.q);
  EXPECT_EQ(s.p, before.p);
  EXPECT_EQ(s.lambda, before.lambda);
  EXPECT_EQ(s.t, before.t);
  o.max_gap_iterations = 20;  // enough: the hitch closes in the first step
  ASSERT_EQ(step(model, ws, s, o), Status::Ok) << ws.message();
  Vector gap(model.num_holonomic());
  model.gap(s.q, gap);
  EXPECT_LE(gap.lpNorm<Eigen::Infinity>(), 1e-12);

  RattleOptions bad;
  bad.gap_tolerance = 0.0;
  testing::expect_error([&] { validate(bad); }, "gap_tolerance = 0 must be positive and finite");
  bad = RattleOptions{};
  bad.max_gap_iterations = 0;
  testing::expect_error([&] { validate(bad); }, "max_gap_iterations = 0 must be at least 1");
  bad = RattleOptions{};
  bad.restart.every = -2;
  testing::expect_error([&] { validate(bad); }, "restart every = -2 must not be negative");
  bad = RattleOptions{};
  bad.restart.mode = RestartMode::Periodic;
  testing::expect_error([&] { validate(bad); }, "restart every = 0 must be at least 1 with RestartMode::Periodic");
  bad = RattleOptions{};
  bad.restart.monitor_every = 0;
  testing::expect_error([&] { validate(bad); }, "monitor_every = 0 must be at least 1 with RestartMode::Auto");
  bad.restart.mode = RestartMode::Never;
  EXPECT_NO_THROW(validate(bad));
  bad.restart.tolerance = -1.0;
  testing::expect_error([&] { validate(bad); }, "restart tolerance = -1 must be 0 (h^3) or positive and finite");
  testing::expect_error([] {
    RestartOptions parsed;
    set_restart(parsed, "sometimes");
  }, "restart 'sometimes': expected auto, 0 (never) or a number of steps K from 1 to 1e9");
  testing::expect_error([] { hitch_mode_from_string("rigid"); },
                        "unknown hitch mode 'rigid' (valid: oneform, holonomic)");
}

}  // namespace
}  // namespace nonholo
