// The fused chain step (core/src/step/chain/chain_sweep.cpp) against the step built from separate passes
// around CHOLMOD (rattle.cpp's general path) on the same states; its diagnostics against
// diagnose(); its failures; and the element API's checks (nonholo/elements.hpp).
#include <nonholo/diagnostics.hpp>
#include <nonholo/dynamics.hpp>
#include <nonholo/model_builder.hpp>
#include <nonholo/rattle.hpp>
#include <nonholo/restart.hpp>
#include <nonholo/scenarios/scene.hpp>
#include <nonholo/start.hpp>
#include <nonholo/sparse/banded_ldlt.hpp>

#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "support/scenes.hpp"
#include "support/expect_error.hpp"

namespace nonholo {
namespace {

using sparse::Backend;

using testing::scene;

double relative(const Vector& a, const Vector& b) {
  const double scale = std::max(1.0, b.lpNorm<Eigen::Infinity>());
  return (a - b).lpNorm<Eigen::Infinity>() / scale;
}

struct Case {
  std::string scene;
  std::vector<std::string> sets;
};

const std::vector<Case> kCases{
    {"sleigh", {}},
    {"sleigh_chain", {"bodies=1"}},
    {"sleigh_chain", {"bodies=2"}},  // kd = 2: the general holonomic passes
    {"sleigh_chain", {"bodies=40"}},
    {"sleigh_chain", {"bodies=40", "k=3"}},                // springs: forces at t_{k+1} one body ahead
    {"sleigh_chain", {"bodies=40", "hitched=0", "k=2"}},  // C diagonal (kd = 0)
    {"wheeled_train", {"bodies=30"}},                     // thrust, generated parameters
};

// A chain's band is set up from its layout, without C's pattern, and factorize() writes its
// rows from mu: the bandwidth is the pattern's, and the solves are CHOLMOD's (to round-off)
// at a state far from the start, on the scenes and on a chain whose bodies have different
// rows (no knife edge on body 1, no hitch from body 2: kd = 3).
TEST(ChainSweep, ItsBandIsThePatternsAndSolvesAsCholmod) {
  std::vector<scenarios::SceneSetup> setups;
  for (const Case& c : kCases) setups.push_back(scene(c.scene, c.sets));
  {
    ModelBuilder b;
    for (int i = 0; i < 4; ++i) {
      const std::string s = std::to_string(i);
      b.add_planar_body({"x" + s, "y" + s, "theta" + s}, 1.0 + 0.3 * i, 0.5 + 0.2 * i);
    }
    b.add_knife_edge({0, 0.2});
    b.add_hitch({0, 1, 0.5, 0.4});
    b.add_hitch({1, 2, 0.3, 0.6});
    b.add_knife_edge({2, -0.1});
    b.add_knife_edge({3, 0.3});
    Vector q = Vector::Zero(12), v = Vector::Zero(12);
    q << 0, 0, 0, -0.9, 0, 0, -1.8, 0, 0, -2.5, 0, 0;
    v[0] = 1.0, v[2] = 0.3;
    setups.push_back({b.build(), 0.0, q, v});
  }
  for (const auto& setup : setups) {
    const Model& model = setup.model;
    ASSERT_TRUE(model.is_chain());
    Workspace fused(model), general(model, {Backend::CholmodNatural});
    const int m = model.num_one_forms();
    EXPECT_EQ(fused.banded()->bandwidth(), sparse::half_bandwidth(model.gram().pattern())) << m;
    RattleOptions o;
    o.hitch = HitchMode::OneForm;
    State s = start_from_velocity(model, general, 0.0, setup.q0, setup.v0);
    for (int k = 0; k < 50; ++k) ASSERT_EQ(step(model, general, s, o), Status::Ok) << general.message();
    Vector rhs(m), a(m), b(m);
    for (int r = 0; r < m; ++r) rhs[r] = std::cos(1.0 + 0.7 * r);
    for (Workspace* ws : {&fused, &general}) {
      ASSERT_EQ(ws->evaluate_one_forms(s.q), Status::Ok);
      ASSERT_EQ(ws->factorize(1e-14), Status::Ok) << ws->message();
    }
    ASSERT_EQ(fused.solve(rhs.data(), a.data()), Status::Ok);
    ASSERT_EQ(general.solve(rhs.data(), b.data()), Status::Ok);
    EXPECT_LE(relative(a, b), 1e-12) << m;
  }
}

// From the same state at many points of a trajectory, one fused step and one step of the
// general path forced through CHOLMOD: the same q, p~, lambda~ and force to 1e-12 relative,
// in both hitch modes, with the period-2 mode's measurement and restarts as by default.
TEST(ChainSweep, AgreesWithTheGeneralPathThroughCholmod) {
  for (const Case& c : kCases)
    for (HitchMode hitch : {HitchMode::OneForm, HitchMode::Holonomic}) {
      const auto setup = scene(c.scene, c.sets);
      const Model& model = setup.model;
      ASSERT_TRUE(model.is_chain()) << c.scene;
      Workspace fused(model), general(model, {Backend::CholmodNatural});
      ASSERT_TRUE(fused.fused());
      ASSERT_FALSE(general.fused());
      ASSERT_STREQ(fused.backend_name(), "banded");
      RattleOptions o;
      o.hitch = hitch;
      State s = start_from_velocity(model, fused, 0.0, setup.q0, setup.v0);
      double worst = 0.0;
      for (int k = 0; k < 300; ++k) {
        State a = s, b = s;
        ASSERT_EQ(step(model, fused, a, o), Status::Ok) << fused.message();
        ASSERT_EQ(step(model, general, b, o), Status::Ok) << general.message();
        worst = std::max({worst, relative(a.q, b.q), relative(a.p, b.p), relative(a.lambda, b.lambda),
                          relative(a.force, b.force)});
        EXPECT_EQ(a.restarts, b.restarts);
        s = a;
      }
      EXPECT_LE(worst, 1e-12) << c.scene << " " << (c.sets.empty() ? "" : c.sets[0]) << " " << to_string(hitch);
    }
}

// A chain whose bodies carry the same data is read from its first and last entries
// (ElementSet::chain_uniform): a chain that differs from the uniform one in a single field of
// a single body must not be taken for uniform. Each variant steps as the general path does.
TEST(ChainSweep, AChainDifferingInOneBodyIsReadBodyByBody) {
  const int n = 9;
  for (int variant = 0; variant < 8; ++variant) {
    ModelBuilder b;
    // The one body that differs: the fifth, the last (4), the first (6), the second (7; the
    // builder then keeps the first as the common entry until the second differs).
    auto odd = [&](int i) { return i == (variant == 4 ? n - 1 : variant == 6 ? 0 : variant == 7 ? 1 : 4); };
    for (int i = 0; i < n; ++i) {
      const std::string s = std::to_string(i);
      b.add_planar_body({"x" + s, "y" + s, "theta" + s}, odd(i) && (variant == 0 || (variant >= 4 && variant != 5)) ? 1.7 : 1.0,
                        odd(i) && variant == 1 ? 0.9 : 0.5);
    }
    for (int i = 0; i < n; ++i) {
      b.add_knife_edge({i, odd(i) && variant == 2 ? 0.35 : 0.1});
      if (i + 1 < n) b.add_hitch({i, i + 1, odd(i) && variant == 3 ? 0.8 : 0.5, odd(i) && variant == 5 ? 0.7 : 0.4});
    }
    Vector q = Vector::Zero(3 * n), v = Vector::Zero(3 * n);
    for (int i = 0; i < n; ++i) q[3 * i] = -0.9 * i;  // hitches closed: 0.5 + 0.4 apart
    if (variant == 3) for (int i = 5; i < n; ++i) q[3 * i] -= 0.3;
    if (variant == 5) for (int i = 5; i < n; ++i) q[3 * i] -= 0.3;
    v[0] = 1.0;
    v[2] = 0.4;
    const Model model = b.build();
    for (HitchMode hitch : {HitchMode::OneForm, HitchMode::Holonomic}) {
      Workspace fused(model), general(model, {Backend::CholmodNatural});
      ASSERT_TRUE(fused.fused());
      RattleOptions o;
      o.hitch = hitch;
      State a = start_from_velocity(model, general, 0.0, q, v), c = a;
      for (int k = 0; k < 100; ++k) {
        ASSERT_EQ(step(model, fused, a, o), Status::Ok) << fused.message();
        ASSERT_EQ(step(model, general, c, o), Status::Ok) << general.message();
      }
      EXPECT_LE(relative(a.q, c.q), 1e-12) << variant << " " << to_string(hitch);
      EXPECT_LE(relative(a.p, c.p), 1e-12) << variant << " " << to_string(hitch);
    }
  }
}

// The workspace caches mu(q), C(q) and sin/cos(q) between steps, and fills mu lazily after a
// one-form step: switching hitch modes, restarting and diagnosing between steps must never
// read a stale cache. Same trajectory as the general path through CHOLMOD.
TEST(ChainSweep, CachesStayRightAcrossModesRestartsAndDiagnostics) {
  const auto setup = scene("sleigh_chain", {"bodies=12", "k=2"});
  const Model& model = setup.model;
  Workspace fused(model), general(model, {Backend::CholmodNatural}), probe(model);
  State a = start_from_velocity(model, fused, 0.0, setup.q0, setup.v0);
  double worst = 0.0;
  for (int k = 0; k < 200; ++k) {
    RattleOptions o;
    o.hitch = (k / 3) % 2 ? HitchMode::Holonomic : HitchMode::OneForm;
    if (k % 7 == 0) o.restart.monitor_every = 1;
    State b = a;  // the same state; the general workspace's caches never hold it
    ASSERT_EQ(step(model, fused, a, o), Status::Ok) << fused.message();
    ASSERT_EQ(step(model, general, b, o), Status::Ok) << general.message();
    worst = std::max({worst, relative(a.q, b.q), relative(a.p, b.p), relative(a.lambda, b.lambda)});
    if (k % 5 == 0) {  // diagnose and restart on the fused workspace between steps
      EXPECT_NEAR(diagnose(model, fused, a, o.h).residual, diagnose(model, probe, a, o.h).residual, 1e-15);
      State c = a;
      ASSERT_EQ(restart(model, fused, a, o), Status::Ok);
      ASSERT_EQ(restart(model, general, c, o), Status::Ok);
      worst = std::max({worst, relative(a.p, c.p), relative(a.lambda, c.lambda)});
    }
  }
  EXPECT_LE(worst, 1e-12);
}

// The whole trajectory at orders 4 and 6 (composed of fused substeps) against the general path.
TEST(ChainSweep, ComposedStepsAgreeWithTheGeneralPath) {
  const auto setup = scene("sleigh_chain", {"bodies=20", "k=1"});
  for (int order : {4, 6}) {
    RattleOptions o;
    o.order = order;
    o.hitch = HitchMode::OneForm;
    Workspace fused(setup.model), general(setup.model, {Backend::CholmodNatural});
    State a = start_from_velocity(setup.model, fused, 0.0, setup.q0, setup.v0);
    State b = a;
    for (int k = 0; k < 100; ++k) {
      ASSERT_EQ(step(setup.model, fused, a, o), Status::Ok) << fused.message();
      ASSERT_EQ(step(setup.model, general, b, o), Status::Ok) << general.message();
    }
    EXPECT_LE(relative(a.q, b.q), 1e-11) << order;
    EXPECT_LE(relative(a.p, b.p), 1e-11) << order;
  }
}

// A chain of knife edges measures the period-2 mode from its sweep's data (knife_mode.cpp):
// the amplitude of every step equals parasitic_amplitude()'s through mu, the bias and a solve
// on the same state (to the last bit without forces; the springs' forces are evaluated by
// another callback there).
TEST(ChainSweep, KnifeChainMeasuresTheModeAsTheGeneralPath) {
  for (const Case& c : {Case{"sleigh", {}}, Case{"sleigh_chain", {"bodies=40", "hitched=0", "k=2"}}}) {
    const auto setup = scene(c.scene, c.sets);
    const Model& model = setup.model;
    Workspace ws(model);
    ASSERT_TRUE(ws.fused());
    RattleOptions o;
    o.restart.mode = RestartMode::Never;
    o.restart.monitor_every = 1;
    State s = start_from_velocity(model, ws, 0.0, setup.q0, setup.v0);
    for (int k = 0; k < 300; ++k) {
      ASSERT_EQ(step(model, ws, s, o), Status::Ok) << ws.message();
      const double fast = ws.parasitic;
      double general = -1.0;
      ASSERT_EQ(parasitic_amplitude(model, ws, s, o.h, general, 0.0), Status::Ok) << ws.message();
      ASSERT_GT(general, 0.0) << c.scene << " step " << k;
      if (model.has_applied_force())
        EXPECT_NEAR(fast, general, 1e-12 * general) << c.scene << " step " << k;
      else
        EXPECT_EQ(fast, general) << c.scene << " step " << k;
    }
  }
}

// Every chain's measurement from the sweeps' data (chain_measure.cpp) against the general
// path's (continuous_multiplier_at, parasitic_of through CHOLMOD) after one step from the same
// state, in both hitch modes (holonomic: with the gap offset -dlambda/2), measured every step.
// The amplitude is a small difference lambda~ - lambda_s (the fused pass gets it from C d =
// C lambda~ + bias, the general path from lambda_s), so it is compared to the round-off of the
// multipliers themselves: relative to the same measure of mu^T lambda~, (h/2) |mu^T
// lambda~|_{M^-1} / |p~|, they differ by eps sqrt(cond C) or so: 1e-16 (one body) to 1.7e-14
// (two bodies) measured; bound 1e-13.
TEST(ChainSweep, ChainsMeasureTheModeAsTheGeneralPath) {
  for (const Case& c : kCases)
    for (HitchMode hitch : {HitchMode::OneForm, HitchMode::Holonomic}) {
      const auto setup = scene(c.scene, c.sets);
      const Model& model = setup.model;
      Workspace fused(model), general(model, {Backend::CholmodNatural});
      RattleOptions o;
      o.hitch = hitch;
      o.restart.mode = RestartMode::Never;
      o.restart.monitor_every = 1;
      State s = start_from_velocity(model, fused, 0.0, setup.q0, setup.v0);
      double worst = 0.0;
      int measured = 0;
      for (int k = 0; k < 200; ++k) {
        State a = s, b = s;
        ASSERT_EQ(step(model, fused, a, o), Status::Ok) << fused.message();
        ASSERT_EQ(step(model, general, b, o), Status::Ok) << general.message();
        s = a;
        if (std::isnan(general.parasitic)) continue;  // holonomic mode's first step is not measured
        ASSERT_FALSE(std::isnan(fused.parasitic)) << c.scene << " step " << k;
        const Vector constraint = b.force - general.applied;  // mu^T lambda~
        double force2 = 0.0, momentum2 = 0.0;
        const double* w = model.inverse_mass().diagonal();
        for (int i = 0; i < model.num_coordinates(); ++i) {
          force2 += w[i] * constraint[i] * constraint[i];
          momentum2 += w[i] * b.p[i] * b.p[i];
        }
        const double scale = 0.5 * o.h * std::sqrt(force2 / momentum2);
        worst = std::max(worst, std::abs(fused.parasitic - general.parasitic) / scale);
        ++measured;
      }
      EXPECT_GE(measured, 199);
      EXPECT_LE(worst, 1e-13) << c.scene << " " << (c.sets.empty() ? "" : c.sets[0]) << " " << to_string(hitch);
    }
}

// What the sweeps compute for `nonholo run` equals diagnose() of the state they produced.
TEST(ChainSweep, ItsDiagnosticsAreDiagnose) {
  for (const Case& c : kCases) {
    const auto setup = scene(c.scene, c.sets);
    const Model& model = setup.model;
    Workspace ws(model), other(model);
    RattleOptions o;
    o.hitch = HitchMode::OneForm;
    o.restart.mode = RestartMode::Never;  // a restart changes p~ after the sweep: not reused then
    State s = start_from_velocity(model, ws, 0.0, setup.q0, setup.v0);
    for (int k = 0; k < 50; ++k) {
      ASSERT_EQ(step(model, ws, s, o), Status::Ok);
      ASSERT_EQ(ws.step_diagnostics.q, s.q.data()) << "the fused step filled its diagnostics";
      const Diagnostics fast = diagnose_step(model, ws, s, o.h), full = diagnose(model, other, s, o.h);
      const double e = std::abs(full.energy);
      EXPECT_NEAR(fast.energy, full.energy, 1e-13 * e) << c.scene;
      EXPECT_NEAR(fast.energy_post, full.energy_post, 1e-13 * e) << c.scene;
      EXPECT_NEAR(fast.residual, full.residual, 1e-15) << c.scene;
      EXPECT_NEAR(fast.gap, full.gap, 1e-14) << c.scene;
    }
    // A state changed since the step (another buffer) is diagnosed afresh.
    State copy = s;
    copy.p *= 2.0;
    const Diagnostics d = diagnose_step(model, ws, copy, o.h);
    EXPECT_NEAR(d.energy, diagnose(model, other, copy, o.h).energy, 1e-12 * std::abs(d.energy));
  }
}

// A failed pivot test on the fused path: the general path's status and message (naming the
// row), the state untouched, and the next step on the same workspace still right.
TEST(ChainSweep, AFailedPivotLeavesTheStateAsItWas) {
  const auto setup = scene("sleigh_chain", {"bodies=10"});
  const Model& model = setup.model;
  Workspace ws(model), general(model, {Backend::CholmodNatural});
  State s = start_from_velocity(model, ws, 0.0, setup.q0, setup.v0);
  ASSERT_EQ(step(model, ws, s, {0.01}), Status::Ok);
  const State before = s;
  RattleOptions strict;
  strict.min_pivot_ratio = 0.9;  // every coupled row of a chain has a pivot ratio below this
  const Status fused_status = step(model, ws, s, strict);
  EXPECT_EQ(fused_status, Status::NearlyDependentOneForms) << ws.message();
  EXPECT_NE(std::string(ws.message()).find("pivot of row"), std::string::npos) << ws.message();
  EXPECT_TRUE(s.q == before.q && s.p == before.p && s.lambda == before.lambda && s.force == before.force);
  State b = before;
  EXPECT_EQ(step(model, general, b, strict), Status::NearlyDependentOneForms);
  State a = before;
  b = before;
  ASSERT_EQ(step(model, ws, a, {0.01}), Status::Ok) << ws.message();
  ASSERT_EQ(step(model, general, b, {0.01}), Status::Ok);
  EXPECT_LE(relative(a.p, b.p), 1e-12);
}

// A blow-up inside the sweep (a non-finite thrust) is reported, not committed.
TEST(ChainSweep, NonFiniteForcesAreRefused) {
  ModelBuilder b;
  for (int i = 0; i < 3; ++i) b.add_planar_body({"x" + std::to_string(i), "y" + std::to_string(i), "t" + std::to_string(i)}, 1, 1);
  for (int i = 0; i < 3; ++i) {
    b.add_knife_edge({i, 0.2});
    if (i < 2) b.add_hitch({i, i + 1, 0.5, 0.5});
  }
  b.add_thrust({1, [](double t) { return t > 0.015 ? NAN : 1.0; }, nullptr});
  const Model model = b.build();
  ASSERT_TRUE(model.is_chain());
  Workspace ws(model);
  Vector q0 = Vector::Zero(9), v0 = Vector::Zero(9);
  q0[3] = -1.0, q0[6] = -2.0, v0[0] = v0[3] = v0[6] = 1.0;
  State s = start_from_velocity(model, ws, 0.0, q0, v0);
  ASSERT_EQ(step(model, ws, s, {0.01}), Status::Ok);
  const State before = s;
  EXPECT_EQ(step(model, ws, s, {0.01}), Status::NonFiniteState) << ws.message();
  EXPECT_TRUE(s.q == before.q && s.p == before.p);
}

// Element models that are not chains (a hitch between bodies 0 and 2, rows out of body order)
// still run, on the general path, and agree with the same system on CHOLMOD.
TEST(ChainSweep, ElementModelsThatAreNotChainsUseTheGeneralPath) {
  ModelBuilder b;
  for (int i = 0; i < 3; ++i) b.add_planar_body({"x" + std::to_string(i), "y" + std::to_string(i), "t" + std::to_string(i)}, 1, 2);
  b.add_knife_edge({1, 0.2});
  b.add_knife_edge({0, 0.1});  // out of body order
  b.add_hitch({0, 2, 0.5, 0.5});
  b.add_torsional_spring({0, 2, 1.0});
  const Model model = b.build();
  EXPECT_FALSE(model.is_chain());
  Workspace ws(model);
  EXPECT_FALSE(ws.fused());
  Vector q0 = Vector::Zero(9), v0 = Vector::Zero(9);
  q0[6] = -1.0, v0[0] = v0[6] = 1.0, v0[4] = 0.3;
  State s = start_from_velocity(model, ws, 0.0, q0, v0);
  for (int k = 0; k < 100; ++k) ASSERT_EQ(step(model, ws, s, {0.01}), Status::Ok) << ws.message();
  EXPECT_LE(diagnose(model, ws, s, 0.01).gap, 1e-12);
}

// Element rows evaluate their own bias: it equals the central difference of their values.
TEST(Elements, BiasIsTheDerivativeOfTheRows) {
  const auto setup = scene("wheeled_train", {"bodies=6"});
  const Model& model = setup.model;
  const int n = model.num_coordinates(), nnz = model.num_one_form_values();
  Vector q = setup.q0, v(n);
  for (int i = 0; i < n; ++i) {
    q[i] += 0.3 * std::sin(1.7 * i);
    v[i] = std::cos(2.3 * i);
  }
  Vector bias(model.num_one_forms()), mu_p(nnz), mu_m(nnz), fd(model.num_one_forms());
  model.analytic_bias(q, v, bias);
  const double d = 1e-6;
  model.one_form_values(q + d * v, mu_p);
  model.one_form_values(q - d * v, mu_m);
  model.mu_times(Vector((mu_p - mu_m) / (2 * d)).data(), v.data(), fd.data());
  EXPECT_LE((bias - fd).lpNorm<Eigen::Infinity>(), 1e-8);
}

TEST(Elements, BadElementsAreRefusedClearly) {
  using testing::expect_error;
  ModelBuilder b;
  b.add_planar_body({"x", "y", "t"}, 1, 1);
  b.add_body({"s"}, Eigen::MatrixXd::Identity(1, 1));
  expect_error([&] { b.add_knife_edge({2, 0.1}); }, "knife edge: body 2 is out of range (the model has 2 bodies");
  expect_error([&] { b.add_knife_edge({1, 0.1}); }, "knife edge: body 1 has 1 coordinates; elements act on planar bodies");
  expect_error([&] { b.add_knife_edge({0, NAN}); }, "knife edge: a = nan must be finite");
  expect_error([&] { b.add_hitch({0, 0, 0.5, 0.5}); }, "hitch: joins body 0 to itself");
  expect_error([&] { b.add_torsional_spring({0, 0, 1.0}); }, "torsional spring: joins body 0 to itself");
  expect_error([&] { b.add_thrust({0, nullptr, nullptr}); }, "thrust on body 0: no force and no torque");

  ModelBuilder mixed;
  mixed.add_planar_body({"x", "y", "t"}, 1, 1);
  mixed.add_knife_edge({0, 0.1});
  mixed.add_one_form({0, 1});
  mixed.one_form_values([](ConstVecRef, VecRef v) { v.setZero(); });
  expect_error([&] { mixed.build(); }, "1 rows from elements (knife edges, hitches) and 1 from add_one_form");

  ModelBuilder callbacks;
  callbacks.add_planar_body({"x", "y", "t"}, 1, 1);
  callbacks.add_knife_edge({0, 0.1});
  callbacks.one_form_values([](ConstVecRef, VecRef v) { v.setZero(); });
  expect_error([&] { callbacks.build(); }, "do not also give one_form_values");

  ModelBuilder spring;
  spring.add_planar_body({"x", "y", "t"}, 1, 1);
  spring.add_planar_body({"x1", "y1", "t1"}, 1, 1);
  spring.add_torsional_spring({0, 1, 1.0});
  spring.potential([](ConstVecRef) { return 0.0; }, [](ConstVecRef, VecRef g) { g.setZero(); });
  expect_error([&] { spring.build(); }, "torsional springs make the model's potential");
}

}  // namespace
}  // namespace nonholo
