// One chain on several threads (core/src/step/chain/chain_partitions.cpp): the partitioned
// step (one-form; holonomic with its corrections, chain_partitions_passes.cpp) against the
// one-thread step (to round-off, q bit for bit in one-form mode), against the general path
// through CHOLMOD (independent), bitwise repeatable for a given thread count, with the
// period-2 mode's measurement and restarts solving with the partitioned factorisation; its
// edge cases (partitions of two bodies, a failing pivot) and its refusals. No allocation:
// test_no_allocation.cpp.
#include <nonholo/diagnostics.hpp>
#include <nonholo/model_builder.hpp>
#include <nonholo/rattle.hpp>
#include <nonholo/start.hpp>

#include <gtest/gtest.h>
#include <omp.h>

#include <cmath>
#include <cstdio>
#include <random>
#include <stdexcept>
#include <string>

#include "run/team_probe.hpp"
#include "step/chain/chain_partitions.hpp"
#include "support/dense_reference.hpp"
#include "support/scenes.hpp"


namespace nonholo {
namespace {

double relative(const Vector& a, const Vector& b) {
  const double scale = std::max(1.0, b.lpNorm<Eigen::Infinity>());
  return (a - b).lpNorm<Eigen::Infinity>() / scale;
}

struct Chain {
  Model model;
  Vector q0, v0;
};

// A chain of n sleighs with random masses, inertias, blades and hitch arms, springs on some
// joints, on a random hitched configuration, the lead pushed and turning.
Chain random_chain(int n, unsigned seed, bool springs = true) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  ModelBuilder b;
  std::vector<double> d(n), f(n);
  for (int i = 0; i < n; ++i) {
    const std::string s = std::to_string(i);
    b.add_planar_body({"x" + s, "y" + s, "t" + s}, 0.5 + u(rng), 0.05 + 0.2 * u(rng));
  }
  for (int i = 0; i < n; ++i) {
    b.add_knife_edge({i, -0.2 + 0.5 * u(rng)});
    d[i] = 0.3 + 0.4 * u(rng), f[i] = 0.3 + 0.4 * u(rng);
    if (i + 1 < n) b.add_hitch({i, i + 1, d[i], f[i]});
    if (springs && i + 1 < n && u(rng) < 0.6) b.add_torsional_spring({i, i + 1, 0.5 + 2.0 * u(rng), 0.1 * u(rng)});
  }
  Chain c{b.build(), Vector::Zero(3 * n), Vector::Zero(3 * n)};
  for (int i = 0; i < n; ++i) {
    c.q0[3 * i + 2] = 0.4 * (u(rng) - 0.5);
    if (i > 0) {  // x_i = x_{i-1} - d cos(t_{i-1}) - f cos(t_i)
      c.q0[3 * i] = c.q0[3 * i - 3] - d[i - 1] * std::cos(c.q0[3 * i - 1]) - f[i - 1] * std::cos(c.q0[3 * i + 2]);
      c.q0[3 * i + 1] = c.q0[3 * i - 2] - d[i - 1] * std::sin(c.q0[3 * i - 1]) - f[i - 1] * std::sin(c.q0[3 * i + 2]);
    }
    c.v0[3 * i] = 1.0, c.v0[3 * i + 2] = 0.5 * (u(rng) - 0.5);
  }
  return c;
}

WorkspaceOptions on_threads(int threads) {
  WorkspaceOptions o;
  o.threads = threads;
  return o;
}

RattleOptions one_form(double h = 0.01) {
  RattleOptions o;
  o.h = h;
  o.hitch = HitchMode::OneForm;
  return o;
}

TEST(ChainThreads, TheWorkspaceSplitsTheCommonChainOnly) {
  const Chain c = random_chain(12, 1);
  EXPECT_EQ(Workspace(c.model).threads(), 1);
  EXPECT_EQ(Workspace(c.model, on_threads(4)).threads(), 4);
  EXPECT_EQ(Workspace(c.model, on_threads(6)).threads(), 6);  // partitions of 2 bodies
  try {
    Workspace ws(c.model, on_threads(7));
    ADD_FAILURE() << "7 threads for 12 bodies were accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("at most 6 threads"), std::string::npos) << e.what();
  }
  EXPECT_THROW(Workspace(c.model, on_threads(0)), std::invalid_argument);
  // Not the common chain (knife edges and springs, no hitches: C diagonal): one thread, said by
  // threads() and max_step_threads().
  ModelBuilder b;
  for (int i = 0; i < 6; ++i)
    b.add_planar_body({"x" + std::to_string(i), "y" + std::to_string(i), "t" + std::to_string(i)}, 1, 1);
  for (int i = 0; i < 6; ++i) {
    b.add_knife_edge({i, 0.1});
    if (i < 5) b.add_torsional_spring({i, i + 1, 1.0, 0.0});
  }
  const Model knives = b.build();
  ASSERT_TRUE(knives.is_chain());
  EXPECT_EQ(max_step_threads(knives), 1);
  EXPECT_EQ(Workspace(knives, on_threads(2)).threads(), 1);
  EXPECT_EQ(max_step_threads(c.model), 6);
}

// The tail partition's band lives in the chain's own band: in the rows the split leaves unused
// and two spare rows (chain_partitions.hpp), for the run's caches and for a second set
// (Workspace::make_held: the accuracy check's) alike; one thread keeps no spare rows. The
// tests around this one check that the steps on it agree with one thread's.
TEST(ChainThreads, TheTailsBandLivesInTheChainsOwnBand) {
  const Chain c = random_chain(40, 3);
  EXPECT_EQ(Workspace(c.model).banded()->spare_rows(), 0);
  for (int threads : {2, 3, 4}) {
    Workspace ws(c.model, on_threads(threads));
    HeldCaches held = ws.make_held();
    for (int side = 0; side < 2; ++side) {
      sparse::BandedLdlt& band = *ws.banded();
      const detail::ChainPartitions& cp = *ws.partitions();
      EXPECT_EQ(band.spare_rows(), detail::kTailSpareRows);
      EXPECT_EQ(cp.tail->row(0), band.row(3 * cp.tail_first)) << threads << " threads";
      EXPECT_EQ(cp.tail->row(cp.tail->size()), band.row(band.size() + band.spare_rows()));
      EXPECT_EQ(cp.tail->numeric_state().data, nullptr);
      ws.swap_held(held);
    }
  }
}

// One step from the same states along a trajectory: q bit for bit (the drift is the same
// arithmetic), p~, lambda~ and force as close to the one-thread step as a factorisation in
// another order (CHOLMOD's, natural order) is: the elimination order differs, and on these
// random chains C's condition makes that 1e-13 at 40 bodies and 7e-12 at 101 (measured).
TEST(ChainThreads, OneStepAgreesWithOneThread) {
  for (int n : {14, 40, 101})
    for (int threads : {2, 3, 4, 7}) {
      const Chain c = random_chain(n, 10 + n);
      Workspace one(c.model), many(c.model, on_threads(threads)), general(c.model, {sparse::Backend::CholmodNatural});
      ASSERT_EQ(many.threads(), threads);
      const RattleOptions o = one_form();
      State s = start_from_velocity(c.model, one, 0.0, c.q0, c.v0);
      double worst = 0.0, other = 0.0;
      for (int k = 0; k < 60; ++k) {
        State a = s, b = s, g = s;
        ASSERT_EQ(step(c.model, one, a, o), Status::Ok) << one.message();
        ASSERT_EQ(step(c.model, many, b, o), Status::Ok) << many.message();
        ASSERT_EQ(step(c.model, general, g, o), Status::Ok) << general.message();
        ASSERT_TRUE(a.q == b.q) << "n " << n << " threads " << threads << " step " << k;
        worst = std::max({worst, relative(b.p, a.p), relative(b.lambda, a.lambda), relative(b.force, a.force)});
        other = std::max({other, relative(g.p, a.p), relative(g.lambda, a.lambda), relative(g.force, a.force)});
        EXPECT_EQ(a.restarts, b.restarts);
        s = a;
      }
      EXPECT_LE(worst, std::max(1e-13, 2.0 * other)) << "n " << n << " threads " << threads << ", CHOLMOD " << other;
    }
}

// A generated chain of 10^4 bodies: the solve with the partitioned factorisation is backward
// stable as the one-thread one is (|b - C x| / (|C| |x|) at round-off, C applied as
// mu M^-1 mu^T); the two solutions differ by the conditioning of the separators' Schur
// complement (measured 4e-13 for 2 threads, 1.2e-12 for 7, where CHOLMOD's natural order,
// the one-thread order, agrees to 2e-16).
TEST(ChainThreads, AGeneratedChainSolvesBackwardStably) {
  const auto setup = testing::scene("sleigh_chain", {"bodies=10000", "k=2"});
  const Model& model = setup.model;
  const int m = model.num_one_forms(), n = model.num_velocities();
  const RattleOptions o = one_form();
  Workspace one(model);
  State s = start_from_velocity(model, one, 0.0, setup.q0, setup.v0);
  for (int k = 0; k < 5; ++k) ASSERT_EQ(step(model, one, s, o), Status::Ok);
  Vector rhs(m), x(m), mu_t(n), scaled(n), cx(m);
  for (int r = 0; r < m; ++r) rhs[r] = std::cos(1.0 + 0.7 * r);
  auto backward_error = [&](Workspace& ws, const State& at) {  // C of the q the step arrived at
    EXPECT_EQ(ws.solve(rhs.data(), x.data()), Status::Ok);
    EXPECT_EQ(ws.evaluate_one_forms(at.q), Status::Ok);
    model.mu_transpose_times(ws.mu_values.data(), x.data(), mu_t.data());
    model.inverse_mass().multiply(mu_t.data(), scaled.data());
    model.mu_times(ws.mu_values.data(), scaled.data(), cx.data());
    return (rhs - cx).lpNorm<Eigen::Infinity>() / (rhs.lpNorm<Eigen::Infinity>() + 8.0 * x.lpNorm<Eigen::Infinity>());
  };
  State a = s;
  ASSERT_EQ(step(model, one, a, o), Status::Ok);
  const double single = backward_error(one, a);
  for (int threads : {2, 7}) {
    Workspace many(model, on_threads(threads));
    State b = s;
    ASSERT_EQ(step(model, many, b, o), Status::Ok);
    ASSERT_TRUE(many.factor_parted());
    const double parted = backward_error(many, b);
    EXPECT_LE(parted, 4.0 * single) << threads;
  }
}

// Against the general path through CHOLMOD (a different factorisation altogether), with
// restarts every 7 steps: they solve with the partitioned factorisation. As close as the
// one-thread step is to it: a restart's right-hand side carries the step's round-off in p
// times 2/h, so each solver's lambda after a restart is one sample of a spread (up to 2e-12
// here) whatever the order; the threads' over the one thread's measured 0.91 to 2.02 on 8
// random chains (P = 2 and 5), hence within 4 times.
TEST(ChainThreads, AgreesWithTheGeneralPathThroughCholmod) {
  const Chain c = random_chain(30, 3);
  for (int threads : {2, 5}) {
    Workspace one(c.model), many(c.model, on_threads(threads)), general(c.model, {sparse::Backend::CholmodNatural});
    RattleOptions o = one_form();
    o.restart.mode = RestartMode::Periodic;
    o.restart.every = 7;
    State s = start_from_velocity(c.model, general, 0.0, c.q0, c.v0);
    double worst = 0.0, single = 0.0;
    for (int k = 0; k < 200; ++k) {
      State a = s, b = s, g = s;
      ASSERT_EQ(step(c.model, many, a, o), Status::Ok) << many.message();
      ASSERT_EQ(step(c.model, general, g, o), Status::Ok) << general.message();
      ASSERT_EQ(step(c.model, one, b, o), Status::Ok) << one.message();
      worst = std::max({worst, relative(a.q, g.q), relative(a.p, g.p), relative(a.lambda, g.lambda),
                        relative(a.force, g.force)});
      single = std::max({single, relative(b.q, g.q), relative(b.p, g.p), relative(b.lambda, g.lambda),
                         relative(b.force, g.force)});
      EXPECT_EQ(a.restarts, g.restarts);
      s = g;
    }
    EXPECT_GT(s.restarts, 20);
    EXPECT_LE(worst, std::max(1e-13, 4.0 * single)) << threads << ", one thread " << single;
  }
}

// The period-2 mode measured at every step from the partitioned factorisation (on the threads,
// chain_partitions_measure.cpp) is the one-thread measurement's amplitude, to round-off; and
// a restart at every measurement keeps the two runs together.
TEST(ChainThreads, MeasuresTheModeAsOneThread) {
  for (int threads : {2, 3, 6}) {
    const Chain c = random_chain(13, 20 + threads);
    Workspace one(c.model), many(c.model, on_threads(threads));
    RattleOptions o = one_form();
    o.restart.mode = RestartMode::Never;
    o.restart.monitor_every = 1;
    State s = start_from_velocity(c.model, one, 0.0, c.q0, c.v0);
    s.lambda *= 1.05;  // a mode to measure
    double worst = 0.0, largest = 0.0;
    for (int k = 0; k < 40; ++k) {
      State a = s, b = s;
      ASSERT_EQ(step(c.model, one, a, o), Status::Ok) << one.message();
      ASSERT_EQ(step(c.model, many, b, o), Status::Ok) << many.message();
      ASSERT_TRUE(std::isfinite(one.parasitic) && std::isfinite(many.parasitic));
      worst = std::max(worst, std::abs(many.parasitic - one.parasitic));
      largest = std::max(largest, one.parasitic);
      s = a;
    }
    EXPECT_GT(largest, 1e-5) << "the seeded mode is there to measure";
    EXPECT_LE(worst, 1e-10 * largest + 1e-14) << threads;
  }
}

// The solve with the partitioned factorisation is C^-1 (the one-thread factorisation's, to
// round-off) for any right-hand side.
TEST(ChainThreads, ItsSolveIsTheBandsSolve) {
  const Chain c = random_chain(23, 4);
  const int m = c.model.num_one_forms();
  Workspace one(c.model), many(c.model, on_threads(4));
  State s = start_from_velocity(c.model, one, 0.0, c.q0, c.v0);
  const RattleOptions o = one_form();
  for (int k = 0; k < 20; ++k) ASSERT_EQ(step(c.model, one, s, o), Status::Ok);
  State a = s, b = s;
  ASSERT_EQ(step(c.model, one, a, o), Status::Ok);
  ASSERT_EQ(step(c.model, many, b, o), Status::Ok);
  ASSERT_TRUE(many.factor_parted());
  Vector rhs(m), x1(m), xp(m);
  for (int r = 0; r < m; ++r) rhs[r] = std::cos(1.0 + 0.7 * r);
  ASSERT_EQ(one.solve(rhs.data(), x1.data()), Status::Ok);
  ASSERT_EQ(many.solve(rhs.data(), xp.data()), Status::Ok);
  EXPECT_LE(relative(xp, x1), 1e-12);
  xp = rhs;  // in place
  ASSERT_EQ(many.solve(xp.data(), xp.data()), Status::Ok);
  EXPECT_LE(relative(xp, x1), 1e-12);
}

// 1000 steps with the default options (the mode measured and restarted as it asks): the
// energy, the residual and the gap stay at the one-thread run's round-off, and two runs with
// the same threads are bit for bit the same (threads racing would show here).
TEST(ChainThreads, LongRunsKeepTheOneThreadRoundOffAndRepeatBitwise) {
  const Chain c = random_chain(40, 5);
  const RattleOptions o = one_form();
  auto run = [&](int threads, double& drift, double& residual, double& gap) {
    Workspace ws(c.model, on_threads(threads));
    State s = start_from_velocity(c.model, ws, 0.0, c.q0, c.v0);
    const double e0 = diagnose(c.model, ws, s, o.h).energy;
    drift = residual = gap = 0.0;
    for (int k = 0; k < 1000; ++k) {
      EXPECT_EQ(step(c.model, ws, s, o), Status::Ok) << ws.message();
      const Diagnostics d = diagnose_step(c.model, ws, s, o.h);
      drift = std::max(drift, std::abs(d.energy - e0) / std::abs(e0));
      residual = std::max(residual, d.residual);
      gap = std::max(gap, d.gap);
    }
    return s;
  };
  double drift1, residual1, gap1;
  const State one = run(1, drift1, residual1, gap1);
  for (int threads : {2, 3, 7}) {
    double drift, residual, gap, drift_b, residual_b, gap_b;
    const State a = run(threads, drift, residual, gap), b = run(threads, drift_b, residual_b, gap_b);
    EXPECT_TRUE(a.q == b.q && a.p == b.p && a.lambda == b.lambda && a.force == b.force) << threads;
    EXPECT_EQ(drift, drift_b);
    // The energy drift is the method's (not round-off): the same to a few digits; the residual
    // is round-off of the solve, within a few times the one-thread run's.
    EXPECT_NEAR(drift, drift1, 1e-3 * drift1 + 1e-13) << threads;
    EXPECT_LE(residual, 10.0 * residual1 + 1e-14) << threads << " one thread " << residual1;
    EXPECT_NEAR(gap, gap1, 1e-9 * gap1 + 1e-12) << threads;
    EXPECT_LE(relative(a.q, one.q), 1e-9) << threads;  // 1000 steps of round-off, not a divergence
  }
}

// Two threads of the caller's own parallel region step a chain each at once: one gets the
// worker pool, the other's jobs run on it alone (the pool busy: a team of one), as do jobs
// that find the pool free, in turn; either way the same bits as on their own threads.
TEST(ChainThreads, ASmallerTeamGivesTheSameBits) {
  const Chain c = random_chain(24, 9);
  const RattleOptions o = one_form();
  Workspace reference_ws(c.model, on_threads(4));
  State reference = start_from_velocity(c.model, reference_ws, 0.0, c.q0, c.v0);
  const State start = reference;
  for (int k = 0; k < 50; ++k) ASSERT_EQ(step(c.model, reference_ws, reference, o), Status::Ok);
  State states[2] = {start, start};
  int failures = 0;
#pragma omp parallel num_threads(2) reduction(+ : failures)
  {
    const int i = omp_get_thread_num();
    Workspace ws(c.model, on_threads(4));
    for (int k = 0; k < 50; ++k) failures += step(c.model, ws, states[i], o) != Status::Ok;
  }
  EXPECT_EQ(failures, 0);
  for (const State& s : states)
    EXPECT_TRUE(s.q == reference.q && s.p == reference.p && s.lambda == reference.lambda && s.force == reference.force);
}

// The driven train (a thrust on the lead, springs): its thrust is evaluated once on the calling
// thread and read by the partitions; the run agrees with one thread's, and a thrust that throws
// fails the step as on one thread, the state untouched.
TEST(ChainThreads, ADrivenTrainAgreesAndAThrowingThrustFailsAlike) {
  const auto setup = testing::scene("wheeled_train", {"bodies=30"});
  ASSERT_EQ(max_step_threads(setup.model), 15);
  Workspace one(setup.model), many(setup.model, on_threads(3));
  ASSERT_EQ(many.threads(), 3);
  const RattleOptions o = one_form();
  State a = start_from_velocity(setup.model, one, 0.0, setup.q0, setup.v0);
  State b = a;
  double worst = 0.0;
  for (int k = 0; k < 300; ++k) {
    ASSERT_EQ(step(setup.model, one, a, o), Status::Ok) << one.message();
    ASSERT_EQ(step(setup.model, many, b, o), Status::Ok) << many.message();
    worst = std::max({worst, relative(b.q, a.q), relative(b.p, a.p), relative(b.force, a.force)});
  }
  EXPECT_LE(worst, 1e-11) << "300 steps of round-off";
  ModelBuilder builder;  // the same kind of chain with a thrust that throws after t = 0.05
  for (int i = 0; i < 8; ++i)
    builder.add_planar_body({"x" + std::to_string(i), "y" + std::to_string(i), "t" + std::to_string(i)}, 1, 0.2);
  for (int i = 0; i < 8; ++i) {
    builder.add_knife_edge({i, 0.1});
    if (i < 7) builder.add_hitch({i, i + 1, 0.5, 0.5});
  }
  builder.add_thrust({5, [](double t) -> double {
                        if (t > 0.05) throw std::runtime_error("thrust table ends");
                        return 1.0;
                      }, nullptr});
  const Model thrown = builder.build();
  Vector q0 = Vector::Zero(24), v0 = Vector::Zero(24);
  for (int i = 0; i < 8; ++i) q0[3 * i] = -1.0 * i, v0[3 * i] = 1.0;
  Workspace t1(thrown), t4(thrown, on_threads(4));
  State s1 = start_from_velocity(thrown, t1, 0.0, q0, v0), s4 = s1;
  Status last1 = Status::Ok, last4 = Status::Ok;
  for (int k = 0; k < 10 && last1 == Status::Ok; ++k) last1 = step(thrown, t1, s1, o);
  for (int k = 0; k < 10 && last4 == Status::Ok; ++k) last4 = step(thrown, t4, s4, o);
  EXPECT_NE(last1, Status::Ok);
  EXPECT_EQ(last4, last1) << t4.message();
  EXPECT_STREQ(t4.message(), t1.message());
  EXPECT_EQ(s4.steps, s1.steps);
  EXPECT_LE(relative(s4.q, s1.q), 1e-13) << "the state is the one before the failed step, in both";
}

// A pivot test failing under partitions: the one-thread step's status, a message naming a
// row, the state untouched, and the next step right.
TEST(ChainThreads, AFailedPivotLeavesTheStateAsItWas) {
  const Chain c = random_chain(12, 6);
  Workspace one(c.model), many(c.model, on_threads(3));
  State s = start_from_velocity(c.model, one, 0.0, c.q0, c.v0);
  ASSERT_EQ(step(c.model, many, s, one_form()), Status::Ok);
  const State before = s;
  RattleOptions strict = one_form();
  strict.min_pivot_ratio = 0.9;
  State b = before;
  EXPECT_EQ(step(c.model, one, b, strict), Status::NearlyDependentOneForms);
  EXPECT_EQ(step(c.model, many, s, strict), Status::NearlyDependentOneForms) << many.message();
  EXPECT_NE(std::string(many.message()).find("pivot of row"), std::string::npos) << many.message();
  EXPECT_TRUE(s.q == before.q && s.p == before.p && s.lambda == before.lambda && s.force == before.force);
  State a = before;
  b = before;
  ASSERT_EQ(step(c.model, many, a, one_form()), Status::Ok) << many.message();
  ASSERT_EQ(step(c.model, one, b, one_form()), Status::Ok);
  EXPECT_LE(relative(a.p, b.p), 1e-13);
}

// A nearly dependent configuration in the last partition, which is factorised from the tail:
// bodies 8 and 10 of 12 so heavy that body 9 alone moves under its five rows (its knife edge,
// two hitches), so the last of them to be eliminated fails. The message names a row of body 9's
// in the chain's numbering, on one thread and on two (where the tail eliminates them in
// reverse order: another of the five; the chain's rows of the builder's model carry no
// labels), and the state is untouched.
TEST(ChainThreads, APivotFailingInTheTailNamesItsBody) {
  ModelBuilder b;
  for (int i = 0; i < 12; ++i) {
    const double mass = i == 8 || i == 10 ? 1e12 : 1.0;
    b.add_planar_body({"x" + std::to_string(i), "y" + std::to_string(i), "t" + std::to_string(i)}, mass, 0.1 * mass);
  }
  for (int i = 0; i < 12; ++i) {
    b.add_knife_edge({i, 0.1});
    if (i < 11) b.add_hitch({i, i + 1, 0.5, 0.5});
  }
  const Model model = b.build();
  Vector q0 = Vector::Zero(36), v0 = Vector::Zero(36);
  for (int i = 0; i < 12; ++i) q0[3 * i] = -1.0 * i, v0[3 * i] = 1.0;
  Workspace one(model), two(model, on_threads(2));
  ASSERT_EQ(two.threads(), 2);
  RattleOptions o = one_form();
  o.min_pivot_ratio = 1e-6;
  for (Workspace* ws : {&one, &two}) {
    State s = start_from_velocity(model, one, 0.0, q0, v0);
    const State before = s;
    ASSERT_EQ(step(model, *ws, s, o), Status::NearlyDependentOneForms) << ws->threads() << ": " << ws->message();
    const std::string message = ws->message();
    int row = -1;
    ASSERT_EQ(std::sscanf(message.c_str(), "pivot of row %d", &row), 1) << message;
    EXPECT_TRUE(row >= 25 && row <= 29) << ws->threads() << ": " << message;  // 3*9-2 .. 3*9+2
    EXPECT_TRUE(s.q == before.q && s.p == before.p);
  }
}

// Hitch modes alternating on the same workspace (options changed between steps): each
// holonomic step corrects with the factorisation the one-form step before it left, and agrees
// with a one-thread workspace.
TEST(ChainThreads, HolonomicStepsAfterPartitionedOnesAreRight) {
  const Chain c = random_chain(16, 7);
  Workspace one(c.model), many(c.model, on_threads(2));
  RattleOptions holonomic = one_form();
  holonomic.hitch = HitchMode::Holonomic;
  State a = start_from_velocity(c.model, one, 0.0, c.q0, c.v0), b = a;
  for (int k = 0; k < 10; ++k) {
    const RattleOptions& o = k % 2 ? holonomic : one_form();
    ASSERT_EQ(step(c.model, one, a, o), Status::Ok) << one.message();
    ASSERT_EQ(step(c.model, many, b, o), Status::Ok) << many.message();
  }
  EXPECT_LE(relative(b.q, a.q), 1e-13);
  EXPECT_LE(relative(b.p, a.p), 1e-12);
}

// Holonomic hitches: the position corrections solve with the partitioned factorisation of
// C(q_k) the last step left (chain_partitions_passes.cpp) and the kicked sweep runs on the
// threads. One step from the threads' own trajectory, against a one-thread workspace stepping
// from the same state. The corrections stop once the gaps are below gap_tolerance, so where
// each solver stops differs (and below q's last bit only p sees it): another elimination order
// is another sample of that spread (CHOLMOD's differed from one thread's by 0.03 to 11 times
// the threads' on 72 random chains), so the test bounds it a priori. Two q closing the gaps to
// tol along the same directions M^-1 mu^T differ by at most 2 tol |M^-1 mu^T C^-1|; p by M/h
// and lambda by (2/h^2) |C^-1 mu| times that (norms at q_0, twice for C's change over the run;
// measured at most 0.003, 0.0007 and 0.0074 of these bounds over those chains). And the
// corrections are the same ones: as many as on one thread (equal in all 72).
TEST(ChainThreads, HolonomicStepsAgreeWithOneThread) {
  for (int n : {14, 40, 101})
    for (int threads : {2, 3, 4, 7}) {
      const Chain c = random_chain(n, 30 + n);
      Workspace one(c.model), many(c.model, on_threads(threads));
      RattleOptions o = one_form();
      o.hitch = HitchMode::Holonomic;
      const Eigen::MatrixXd mass = testing::dense_mass(c.model), minv = mass.inverse();
      const Eigen::MatrixXd mu = testing::dense_one_forms(c.model, c.q0);
      const Eigen::MatrixXd cinv = (mu * minv * mu.transpose()).inverse();
      const double spread = 2.0 * 2.0 * o.gap_tolerance * (minv * mu.transpose() * cinv).lpNorm<Eigen::Infinity>();
      const double q_bound = spread, p_bound = mass.lpNorm<Eigen::Infinity>() * spread / o.h;
      const double lambda_bound = 2.0 / (o.h * o.h) * (cinv * mu).lpNorm<Eigen::Infinity>() * spread;
      State b = start_from_velocity(c.model, many, 0.0, c.q0, c.v0);
      double dq = 0.0, dp = 0.0, dl = 0.0;
      long corrected = 0, corrected_one = 0;
      for (int k = 0; k < 60; ++k) {
        State a = b;
        ASSERT_EQ(step(c.model, one, a, o), Status::Ok) << one.message();
        const long factorizations = many.factorizations;
        ASSERT_EQ(step(c.model, many, b, o), Status::Ok) << many.message();
        // After the first step the corrections reuse the partitioned C(q_k): one factorisation.
        if (k > 0) {
          EXPECT_EQ(many.factorizations - factorizations, 1) << k;
        }
        corrected += many.gap_iterations;
        corrected_one += one.gap_iterations;
        dq = std::max(dq, (b.q - a.q).lpNorm<Eigen::Infinity>());
        dp = std::max(dp, (b.p - a.p).lpNorm<Eigen::Infinity>());
        dl = std::max(dl, (b.lambda - a.lambda).lpNorm<Eigen::Infinity>());
        ASSERT_LE(many.step_diagnostics.gap, o.gap_tolerance) << k;
      }
      const std::string where = "n " + std::to_string(n) + " threads " + std::to_string(threads);
      EXPECT_GE(corrected, 60) << "every step corrects its gaps at least once";
      EXPECT_LE(std::abs(corrected - corrected_one), 2) << where << ": " << corrected << " against " << corrected_one;
      EXPECT_LE(dq, q_bound) << where;
      EXPECT_LE(dp, p_bound) << where;
      EXPECT_LE(dl, lambda_bound) << where;
    }
}

// Holonomic runs of 1000 steps: bit for bit the same for the same threads, the energy and gaps
// as on one thread.
TEST(ChainThreads, HolonomicRunsRepeatBitwise) {
  const Chain c = random_chain(40, 8);
  RattleOptions o = one_form();
  o.hitch = HitchMode::Holonomic;
  auto run = [&](int threads, double& drift, double& gap) {
    Workspace ws(c.model, on_threads(threads));
    State s = start_from_velocity(c.model, ws, 0.0, c.q0, c.v0);
    const double e0 = diagnose(c.model, ws, s, o.h).energy;
    drift = gap = 0.0;
    for (int k = 0; k < 1000; ++k) {
      EXPECT_EQ(step(c.model, ws, s, o), Status::Ok) << ws.message();
      const Diagnostics d = diagnose_step(c.model, ws, s, o.h);
      drift = std::max(drift, std::abs(d.energy - e0) / std::abs(e0));
      gap = std::max(gap, d.gap);
    }
    return s;
  };
  double drift1, gap1;
  const State one = run(1, drift1, gap1);
  for (int threads : {2, 5}) {
    double drift, gap, drift_b, gap_b;
    const State a = run(threads, drift, gap), b = run(threads, drift_b, gap_b);
    EXPECT_TRUE(a.q == b.q && a.p == b.p && a.lambda == b.lambda && a.force == b.force) << threads;
    EXPECT_NEAR(drift, drift1, 1e-3 * drift1 + 1e-13) << threads;
    EXPECT_LE(gap, o.gap_tolerance * 4) << threads << " one thread " << gap1;
    EXPECT_LE(relative(a.q, one.q), 1e-9) << threads;
  }
}

// Workspace::set_team: the partitions run on fewer threads (in turn) with the same bits, the
// team changed between any two steps, in both hitch modes (the run's fallback on busy cores).
TEST(ChainThreads, ChangingTheTeamKeepsTheBits) {
  const Chain c = random_chain(30, 11);
  for (HitchMode mode : {HitchMode::OneForm, HitchMode::Holonomic}) {
    RattleOptions o = one_form();
    o.hitch = mode;
    Workspace steady(c.model, on_threads(4)), switching(c.model, on_threads(4));
    ASSERT_EQ(switching.team(), 4);
    switching.set_team(0);
    EXPECT_EQ(switching.team(), 1) << "clamped";
    switching.set_team(9);
    EXPECT_EQ(switching.team(), 4) << "clamped";
    steady.set_team(2);  // no more threads than the 2 cores of the development machine
    State a = start_from_velocity(c.model, steady, 0.0, c.q0, c.v0), b = a;
    for (int k = 0; k < 60; ++k) {
      switching.set_team(1 + k % 2);
      ASSERT_EQ(step(c.model, steady, a, o), Status::Ok) << steady.message();
      ASSERT_EQ(step(c.model, switching, b, o), Status::Ok) << switching.message();
    }
    EXPECT_TRUE(a.q == b.q && a.p == b.p && a.lambda == b.lambda && a.force == b.force) << to_string(mode);
    EXPECT_EQ(Workspace(c.model).team(), 1);
  }
}

// The run's probe (scenarios' team_probe.hpp) with a clock of its own: a block of steps on the
// run's threads, a block on one, the faster kept until the next probe; on busy cores (one
// thread faster) it falls back and says so, and goes back to the threads when they pay again.
// Steps that also ran the accuracy check's shadow step are not timed; a resumed run's note
// counts its steps from the resume.
TEST(ChainThreads, TheRunsProbeFallsBackToOneThreadWhenTheCoresAreBusy) {
  using scenarios::TeamProbe;
  double now = 0.0, per_step[2] = {0.0, 0.0};  // seconds a step on one thread, on the run's
  int team = 4;
  std::vector<int> teams;
  TeamProbe probe(4, [&](int t) { team = t, teams.push_back(t); }, [&] { return now; });
  long step = 0;
  // shadow: every how many steps (at `phase`) a step also runs a shadow step costing `extra`.
  auto run_steps = [&](TeamProbe& p, int count, int shadow = 0, int phase = 0, double extra = 0.0) {
    for (int k = 0; k < count; ++k) {
      p.before_step(++step);
      const bool heavy = shadow > 0 && step % shadow == phase;
      now += per_step[team == 1 ? 0 : 1] + (heavy ? extra : 0.0);
      p.after_step(!heavy);
    }
  };
  const int cycle = (2 + TeamProbe::kProbeEvery) * TeamProbe::kBlock;
  per_step[0] = 1.0, per_step[1] = 0.6;  // free cores: the threads pay
  run_steps(probe, TeamProbe::kWarmUp + cycle);
  EXPECT_EQ(team, 4);
  EXPECT_EQ(teams, (std::vector<int>{1, 4})) << "the probe's block on one thread, then back";
  EXPECT_EQ(probe.note(), "");
  per_step[1] = 3.0;  // busy cores: a barrier waits for a descheduled thread
  run_steps(probe, cycle);
  EXPECT_EQ(team, 1);
  EXPECT_EQ(probe.steps_on_one(), TeamProbe::kProbeEvery * TeamProbe::kBlock);
  const std::string note = probe.note();
  EXPECT_NE(note.find("the chain's 4 threads ran a step slower than one thread (3e+03 against 1e+03 ms"),
            std::string::npos)
      << note;
  EXPECT_NE(note.find("first at step " + std::to_string(TeamProbe::kWarmUp + cycle + 2 * TeamProbe::kBlock + 1)),
            std::string::npos)
      << note;
  EXPECT_NE(note.find("ran on one thread for 512 of the 1058 steps (the same"), std::string::npos) << note;
  EXPECT_NE(note.find("the same results"), std::string::npos) << note;
  per_step[1] = 0.6;  // free again
  run_steps(probe, cycle);
  EXPECT_EQ(team, 4);
  // A shadow step (10 times a step) every 16 steps, always in the block on the threads (the
  // cycle is a multiple of 16; that block's steps are kWarmUp + 1 ... + 8 modulo the cycle):
  // untimed, it does not tip the choice to one thread.
  static_assert(((2 + TeamProbe::kProbeEvery) * TeamProbe::kBlock) % 16 == 0, "the shadow's phase holds");
  run_steps(probe, 3 * cycle, 16, (TeamProbe::kWarmUp + 4) % 16, 10.0);
  EXPECT_EQ(team, 4);
  EXPECT_EQ(probe.steps_on_one(), TeamProbe::kProbeEvery * TeamProbe::kBlock);
  // A resumed run: its steps continue the run's numbering, its note counts from the resume.
  TeamProbe resumed(4, [&](int t) { team = t; }, [&] { return now; });
  step = 5000;
  per_step[1] = 3.0;
  run_steps(resumed, TeamProbe::kWarmUp + 2 * TeamProbe::kBlock + 10);
  EXPECT_NE(resumed.note().find("first at step " + std::to_string(5001 + TeamProbe::kWarmUp + 2 * TeamProbe::kBlock)),
            std::string::npos)
      << resumed.note();
  EXPECT_NE(resumed.note().find("for 10 of the 28 steps since the resume at step 5001"), std::string::npos)
      << resumed.note();
  TeamProbe single(1, [&](int) { ADD_FAILURE() << "a one-thread run has no team to change"; }, [&] { return now; });
  for (int k = 0; k < 3 * cycle; ++k) single.before_step(k + 1), single.after_step();
  EXPECT_EQ(single.note(), "");
}

}  // namespace
}  // namespace nonholo
