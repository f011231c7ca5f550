// Energy-exact restarts and the automatic control of the period-2 mode (docs/design.md section 8):
// the restart against the closed form of docs/design.md, its invariants (post-momentum energy,
// with a potential the averaged potential too, with forces the work-energy balance; the
// constraint residual; momentum maps), its failures, and long runs with the default options
// against exact solutions and a tight ARKODE reference.
#include <nonholo/diagnostics.hpp>
#include <nonholo/dynamics.hpp>
#include <nonholo/model_builder.hpp>
#include <nonholo/rattle.hpp>
#include <nonholo/reference/integrators.hpp>
#include <nonholo/restart.hpp>
#include <nonholo/scenarios/exact_solutions.hpp>
#include <nonholo/scenarios/run.hpp>
#include <nonholo/scenarios/scene.hpp>
#include <nonholo/start.hpp>

#include <gmock/gmock.h>
#include "support/scenes.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <iostream>
#include <limits>
#include <random>

#include "step/restart_internal.hpp"

namespace nonholo {
namespace {

constexpr double kEps = std::numeric_limits<double>::epsilon();

using testing::scene;

RattleOptions options(const char* restart, double h = 0.01, HitchMode hitch = HitchMode::Holonomic) {
  RattleOptions o;
  o.h = h;
  o.hitch = hitch;
  set_restart(o.restart, restart);
  return o;
}

// Advances s by `steps` steps of o, failing the test on a failed step.
void advance(const Model& model, Workspace& ws, State& s, const RattleOptions& o, long steps) {
  for (long k = 0; k < steps; ++k) ASSERT_EQ(step(model, ws, s, o), Status::Ok) << ws.message();
}

double parasitic(const Model& model, Workspace& ws, const State& s, double h) {
  double a = -1.0;
  EXPECT_EQ(parasitic_amplitude(model, ws, s, h, a), Status::Ok) << ws.message();
  return a;
}

// The sleigh after 60 time units of the plain method: the mode then holds most of the energy.
TEST(Restart, MatchesTheClosedFormAndRemovesTheMode) {
  const auto setup = scene("sleigh");
  const Model& model = setup.model;
  Workspace ws(model);
  State s = start_from_velocity(model, ws, 0.0, setup.q0, setup.v0);
  const double h = 0.01;
  advance(model, ws, s, options("0", h), 6000);
  const double before = parasitic(model, ws, s, h);
  const Diagnostics d0 = diagnose(model, ws, s, h);

  // docs/design.md section 8, computed independently: P = p~^T M^-1 p~, L = lambda_s^T C lambda_s,
  // u = 2E / (P/2 + sqrt(P^2/4 + h^2 L E / 2)), p~ <- sqrt(u) p~, lambda~ <- u lambda_s.
  Vector v(3), lambda_s(1), force(3);
  model.inverse_mass().multiply(s.p.data(), v.data());
  ASSERT_EQ(constraint_multiplier(model, ws, s.t, s.q, v, lambda_s, 1e-12), Status::Ok);
  ASSERT_EQ(ws.evaluate_one_forms(s.q), Status::Ok);
  model.mu_transpose_times(ws.mu_values.data(), lambda_s.data(), force.data());
  const Eigen::Map<const Eigen::Vector3d> minv(model.inverse_mass().diagonal());
  const double P = s.p.dot(v), L = force.dot(minv.cwiseProduct(force)), E = d0.energy_post;
  const double u = 2 * E / (P / 2 + std::sqrt(P * P / 4 + h * h * L * E / 2));
  const Vector p_old = s.p;

  ASSERT_EQ(restart(model, ws, s, options("auto", h)), Status::Ok) << ws.message();
  const Diagnostics d1 = diagnose(model, ws, s, h);
  std::cout << "sleigh at t = 60 (plain method): parasitic amplitude " << before << ", energy of p~ "
            << d0.energy / d0.energy_post << " of E_post; after the restart: amplitude "
            << parasitic(model, ws, s, h) << ", energy of p~ " << d1.energy / d1.energy_post
            << ", E_post change " << std::abs(d1.energy_post - E) / E << ", scale u = " << u << "\n";
  EXPECT_GT(before, 0.1);
  EXPECT_NEAR((s.p - std::sqrt(u) * p_old).norm(), 0.0, 1e-13 * p_old.norm());
  EXPECT_NEAR(s.lambda[0], u * lambda_s[0], 1e-12 * std::abs(lambda_s[0]));
  EXPECT_LE(std::abs(d1.energy_post - E), 4 * kEps * E);
  EXPECT_LE(parasitic(model, ws, s, h), 1e-13);
  EXPECT_LE(d1.residual, 4 * kEps);
  EXPECT_GT(d1.energy / d1.energy_post, 0.9999) << "the energy is back in p~";
  EXPECT_EQ(s.restarts, 1);
}

// With a potential (and no external force) the restart keeps E_post + the averaged V, which
// is what diagnose() reports as energy_post.
TEST(Restart, WithAPotentialKeepsThePostEnergyWithTheAveragedPotential) {
  const auto setup = scene("sleigh_chain", {"bodies=5", "k=2"});
  const Model& model = setup.model;
  ASSERT_TRUE(model.has_potential());
  Workspace ws(model);
  State s = start_from_velocity(model, ws, 0.0, setup.q0, setup.v0);
  const double h = 0.02;
  advance(model, ws, s, options("0", h, HitchMode::OneForm), 5000);
  const double before = parasitic(model, ws, s, h);
  const double e0 = diagnose(model, ws, s, h).energy_post;
  ASSERT_EQ(restart(model, ws, s, options("auto", h)), Status::Ok) << ws.message();
  const Diagnostics d1 = diagnose(model, ws, s, h);
  std::cout << "spring-coupled 5-body chain, t = 100 (plain): amplitude " << before << " -> "
            << parasitic(model, ws, s, h) << ", E_post + V change " << std::abs(d1.energy_post - e0) / e0 << "\n";
  EXPECT_GT(before, 1e-4);
  EXPECT_LE(std::abs(d1.energy_post - e0), 8 * kEps * e0);
  EXPECT_LE(parasitic(model, ws, s, h), 1e-12);
  EXPECT_LE(d1.residual, 1e-15);
}

// With external forces a restart keeps the arriving post-momentum energy, so the discrete
// work-energy identity E_post(k+1/2) - E_post(k-1/2) = h F_k^T M^-1 p~_k holds through
// restarts: the balance stays at round-off over a driven run with many restarts.
TEST(Restart, WithExternalForcesTheWorkEnergyBalanceStaysAtRoundOff) {
  const auto setup = scene("wheeled_train", {"bodies=20"});
  const Model& model = setup.model;
  Workspace ws(model);
  State s = start_from_velocity(model, ws, 0.0, setup.q0, setup.v0);
  const double h = 0.01;
  const RattleOptions o = options("auto", h, HitchMode::OneForm);
  const double e0 = diagnose(model, ws, s, h).energy_post;
  double work = 0.0, balance = 0.0, power = external_power(model, ws, s);
  for (int k = 0; k < 3000; ++k) {
    ASSERT_EQ(step(model, ws, s, o), Status::Ok) << ws.message();
    work += h * power;
    power = external_power(model, ws, s);
    const double e = diagnose(model, ws, s, h).energy_post;
    balance = std::max(balance, std::abs(e - e0 - work) / std::max({e0, e, std::abs(work)}));
  }
  std::cout << "wheeled_train 20 bodies, one-form hitches, t = 30: " << s.restarts << " restarts, work " << work
            << ", balance error " << balance << "\n";
  EXPECT_GT(s.restarts, 10);
  EXPECT_GT(work, 10 * e0);
  EXPECT_LE(balance, 3000 * 4 * kEps);

  // One restart on a driven state with a mode: the multiplier changes, E_post does not.
  advance(model, ws, s, options("0", h, HitchMode::OneForm), 300);
  const Vector lambda = s.lambda;
  const double e = diagnose(model, ws, s, h).energy_post;
  ASSERT_EQ(restart(model, ws, s, o), Status::Ok) << ws.message();
  EXPECT_GT((s.lambda - lambda).norm(), 1e-6 * lambda.norm());
  EXPECT_LE(std::abs(diagnose(model, ws, s, h).energy_post - e), 4 * kEps * e);
}

// The snakeboard's rotor (psi, a horizontal symmetry no one-form touches): the rescale leaves
// p_psi alone, bit for bit, through every restart of a long run.
TEST(Restart, SnakeboardRotorMomentumIsUnchangedToTheLastBit) {
  for (const std::vector<std::string>& sets : {std::vector<std::string>{}, {"u_phi_amp=0.05"}}) {
    const auto setup = scene("snakeboard", sets);
    const Model& model = setup.model;
    Workspace ws(model);
    State s = start_from_velocity(model, ws, 0.0, setup.q0, setup.v0);
    const double rotor = s.p[3];
    const double e0 = diagnose(model, ws, s, 0.01).energy_post;
    Vector j(1);
    long changed = 0;
    for (int k = 0; k < 100000; ++k) {
      ASSERT_EQ(step(model, ws, s, RattleOptions{}), Status::Ok) << ws.message();
      evaluate_momentum_maps(model, s, j);
      changed += j[0] != rotor;
    }
    const double e = diagnose(model, ws, s, 0.01).energy_post;
    std::cout << "snakeboard " << (sets.empty() ? "free" : sets[0]) << ", t = 1000: " << s.restarts
              << " restarts, rotor momentum changed at " << changed << " steps, E_post change " << std::abs(e - e0) / e0
              << "\n";
    EXPECT_GT(s.restarts, 20);
    EXPECT_EQ(changed, 0);
    if (sets.empty()) {
      EXPECT_LE(std::abs(e - e0), 1e-12 * e0);
    }
  }
}

// The nonholonomic particle with a momentum map that reads constrained coordinates
// (J = p_x + 2 p_z, not conserved): the rescale keeps it to round-off and keeps the energy.
// A map that is not linear in p is refused, and the state is left as it was.
Model particle_with_map(MomentumMap map) {
  ModelBuilder b;
  b.add_body({"x", "y", "z"}, Eigen::Matrix3d::Identity());
  b.add_one_form({0, 1, 2});
  b.one_form_values([](ConstVecRef q, VecRef mu) { mu << -q[1], 0.0, 1.0; });
  b.momentum_map("J", std::move(map));
  return b.build();
}

TEST(Restart, MomentumMapsThatReadConstrainedCoordinatesAreKept) {
  const Model model = particle_with_map([](ConstVecRef, ConstVecRef p) { return p[0] + 2.0 * p[2]; });
  Workspace ws(model);
  StartOptions zero;
  zero.multiplier = InitialMultiplier::Zero;  // lambda~_0 = 0: a parasitic amplitude of order h
  State s = start_from_velocity(model, ws, 0.0, Eigen::Vector3d(0.0, 0.5, 0.0), Eigen::Vector3d(1.0, 1.0, 0.5), zero);
  const double h = 0.05;
  advance(model, ws, s, options("0", h), 7);
  Vector j0(1), j1(1);
  evaluate_momentum_maps(model, s, j0);
  const double e0 = diagnose(model, ws, s, h).energy_post, before = parasitic(model, ws, s, h);
  const Vector p_old = s.p;
  ASSERT_EQ(restart(model, ws, s, options("auto", h)), Status::Ok) << ws.message();
  evaluate_momentum_maps(model, s, j1);
  const Diagnostics d = diagnose(model, ws, s, h);
  std::cout << "particle, J = p_x + 2 p_z: amplitude " << before << " -> " << parasitic(model, ws, s, h)
            << ", J change " << j1[0] - j0[0] << ", p~ change " << (s.p - p_old).norm() << ", E_post change "
            << std::abs(d.energy_post - e0) / e0 << "\n";
  EXPECT_GT(before, 1e-4);
  EXPECT_GT((s.p - p_old).norm(), 1e-8) << "the rescale did something";
  EXPECT_LE(std::abs(j1[0] - j0[0]), 8 * kEps * (std::abs(p_old[0]) + 2 * std::abs(p_old[2])));
  EXPECT_LE(std::abs(d.energy_post - e0), 4 * kEps * e0);
  EXPECT_LE(parasitic(model, ws, s, h), 1e-12);
  EXPECT_LE(d.residual, 1e-15);
}

TEST(Restart, AMomentumMapNotLinearInPIsRefusedAndTheStateKept) {
  // Quadratic: its derivative at p = 0, which the restart probes, is 0.
  const Model model = particle_with_map([](ConstVecRef, ConstVecRef p) { return p[0] * p[1]; });
  Workspace ws(model);
  StartOptions zero;
  zero.multiplier = InitialMultiplier::Zero;
  State s = start_from_velocity(model, ws, 0.0, Eigen::Vector3d(0.0, 0.5, 0.0), Eigen::Vector3d(1.0, 1.0, 0.5), zero);
  const State before = s;
  EXPECT_EQ(restart(model, ws, s, options("auto", 0.05)), Status::RestartFailed);
  EXPECT_THAT(ws.message(), ::testing::HasSubstr("momentum map 'J' would change"));
  EXPECT_THAT(ws.message(), ::testing::HasSubstr("must be linear in p"));
  // Inside a step: the step fails as a whole.
  EXPECT_EQ(step(model, ws, s, options("1", 0.05)), Status::RestartFailed);
  EXPECT_EQ(s.q, before.q);
  EXPECT_EQ(s.p, before.p);
  EXPECT_EQ(s.lambda, before.lambda);
  EXPECT_EQ(s.force, before.force);
  EXPECT_EQ(s.t, before.t);
  EXPECT_EQ(s.restarts, 0);
  // Without restarts the same model integrates (the map is only reported).
  EXPECT_EQ(step(model, ws, s, options("0", 0.05)), Status::Ok);
}

// Holonomic mode: lambda~ settles at lambda_s - dlambda/2 (dlambda the gap correction), an
// O(h) offset; measured about that offset the amplitude keeps the O(h^3) of the mode's seed,
// so automatic restarts stay rare (measured about lambda_s it was O(h^2): a restart every step).
// The measurement schedule skips its pow and logs when the prediction is far below the
// tolerance (restart.cpp): the plan must be the one the logarithms give, near the boundary too.
TEST(AutoRestart, ScheduleIsThatOfTheGrowthFormula) {
  auto reference = [](const RestartOptions& o, double h, ModeWatch& w, long now, double a) {
    long interval = o.monitor_every;
    const double tolerance = o.tolerance_for(h);
    if (!(a <= tolerance)) {
      interval = 1;
    } else if (a > 0.0) {
      double growth = 2.0;
      if (w.last_amplitude > 0.0)
        growth = std::max(1.0, std::pow(a / w.last_amplitude, 1.0 / static_cast<double>(now - w.last_step)));
      if (growth > 1.0)
        interval = std::min(interval, static_cast<long>(std::log(0.5 * tolerance / a) / std::log(growth)));
    }
    w.next_step = now + std::max(1L, interval);
    w.last_step = now;
    w.last_amplitude = a;
  };
  std::mt19937_64 random(12);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  const double h = 0.01, tolerance = h * h * h;
  long checked = 0;
  for (int every : {1, 2, 8, 100}) {
    RestartOptions o;
    o.monitor_every = every;
    for (int trial = 0; trial < 20000; ++trial) {
      ModeWatch w;
      const long k = 1 + static_cast<long>(unit(random) * every);
      w.last_step = 1000;
      w.last_amplitude = trial % 10 == 0 ? 0.0 : tolerance * std::pow(10.0, -6.0 * unit(random));
      const long now = w.last_step + k;
      // Half the trials put the prediction a r^(every/k) within a factor 4 of tolerance / 2.
      double a = tolerance * std::pow(10.0, -6.0 * unit(random));
      if (trial % 2 && w.last_amplitude > 0.0) {
        const double target = 0.5 * tolerance * std::pow(4.0, 2.0 * unit(random) - 1.0);
        // a (a / last)^(every / k) = target: a^(1 + e) = target last^e
        const double e = static_cast<double>(every) / static_cast<double>(k);
        a = std::min(tolerance, std::exp((std::log(target) + e * std::log(w.last_amplitude)) / (1.0 + e)));
      }
      ModeWatch expected = w;
      reference(o, h, expected, now, a);
      const bool restart = detail::plan_after_measurement(o, h, w, now, a);
      EXPECT_EQ(restart, !(a <= tolerance));
      ASSERT_EQ(w.next_step, expected.next_step) << "a " << a << " last " << expected.last_amplitude << " k " << k;
      ++checked;
    }
  }
  EXPECT_EQ(checked, 80000);
}

TEST(AutoRestart, HolonomicModeMeasuresTheModeAboutItsOffset) {
  const auto setup = scene("sleigh_chain", {"bodies=100"});
  double amplitude[2];
  long restarts[2];
  for (int i = 0; i < 2; ++i) {
    const double h = i == 0 ? 0.01 : 0.005;
    Workspace ws(setup.model);
    State s = start_from_velocity(setup.model, ws, 0.0, setup.q0, setup.v0);
    RattleOptions o = options("auto", h);
    o.restart.monitor_every = 1;
    amplitude[i] = 0.0;
    for (long k = 0; k < std::lround(20.0 / h); ++k) {
      ASSERT_EQ(step(setup.model, ws, s, o), Status::Ok) << ws.message();
      if (!std::isnan(ws.parasitic)) amplitude[i] = std::max(amplitude[i], ws.parasitic);
    }
    restarts[i] = s.restarts;
  }
  std::cout << "100-body chain, holonomic hitches, T = 20: max amplitude " << amplitude[0] << " (h = 0.01), "
            << amplitude[1] << " (h = 0.005), ratio " << amplitude[0] / amplitude[1] << "; restarts " << restarts[0]
            << ", " << restarts[1] << "\n";
  EXPECT_GT(amplitude[0] / amplitude[1], 6.0);
  EXPECT_LE(restarts[0] + restarts[1], 2);
}

// The first case: the free 10-body chain with one-form hitches to t = 100, against
// ARKODE Verner at tolerance 1e-12 (whose own error there is about 1e-10).
TEST(AutoRestart, FreeTenBodyChainStaysOnTheReferenceToT100) {
  const auto setup = scene("sleigh_chain", {"bodies=10"});
  const Model& model = setup.model;
  double error[2], post[2];
  long restarts[2];
  Vector reference_q;
  {
    Workspace ws(model);
    const State s = start_from_velocity(model, ws, 0.0, setup.q0, setup.v0);
    Vector v(s.p.size());
    model.inverse_mass().multiply(s.p.data(), v.data());
    reference::Options ro;
    ro.tol = 1e-12;
    ro.h = 1.0;
    reference::Integrator ref(model, reference::Method::ArkodeVerner, ro, 0.0, setup.q0, v);
    ASSERT_EQ(ref.advance_to(100.0), Status::Ok) << ref.message();
    reference_q = ref.q();
  }
  const char* policies[2] = {"auto", "0"};
  for (int i = 0; i < 2; ++i) {
    Workspace ws(model);
    State s = start_from_velocity(model, ws, 0.0, setup.q0, setup.v0);
    const RattleOptions o = options(policies[i], 0.01, HitchMode::OneForm);
    const double e0 = diagnose(model, ws, s, o.h).energy_post;
    post[i] = 0.0;
    for (int k = 0; k < 10000; ++k) {
      ASSERT_EQ(step(model, ws, s, o), Status::Ok) << ws.message();
      post[i] = std::max(post[i], std::abs(diagnose(model, ws, s, o.h).energy_post - e0) / e0);
    }
    ASSERT_NEAR(s.t, 100.0, 1e-9);
    error[i] = (s.q - reference_q).lpNorm<Eigen::Infinity>();
    restarts[i] = s.restarts;
  }
  std::cout << "free 10-body chain, one-form hitches, h = 0.01, t = 100: error " << error[0] << " with automatic restarts ("
            << restarts[0] << "), " << error[1] << " plain; post-momentum energy " << post[0] << " and " << post[1] << "\n";
  EXPECT_LE(error[0], 1e-3);
  EXPECT_LE(post[0], 1e-12);
  EXPECT_GT(error[1], 0.1) << "the plain method is O(1) off: the comparison can fail";
}

// The sleigh over 10^6 steps of 0.01 with the defaults: the post-momentum energy stays at
// round-off, the energy of p~ makes no excursions, and the trajectory follows the exact one.
TEST(AutoRestart, SleighMillionSteps) {
  const auto setup = scene("sleigh");
  const Model& model = setup.model;
  const scenarios::SleighExact exact(1.0, 1.0, 0.2, 1.0, 1.0, 0.0, 0.0, 0.0);
  Workspace ws(model);
  State s = start_from_velocity(model, ws, 0.0, setup.q0, setup.v0);
  const double h = 0.01;
  const Diagnostics d0 = diagnose(model, ws, s, h);
  double post = 0.0, energy = 0.0;
  long measured = 0;
  for (long k = 0; k < 1000000; ++k) {
    ASSERT_EQ(step(model, ws, s, RattleOptions{}), Status::Ok) << ws.message();
    measured += !std::isnan(ws.parasitic);
    const Diagnostics d = diagnose(model, ws, s, h);
    post = std::max(post, std::abs(d.energy_post - d0.energy_post) / d0.energy_post);
    energy = std::max(energy, std::abs(d.energy - d0.energy) / d0.energy);
  }
  const Eigen::Vector2d centre = exact.positions({s.t}).back();
  const double error = std::max((s.q.head<2>() - centre).norm(), std::abs(s.q[2] - exact.heading(s.t)));
  std::cout << "sleigh, 10^6 steps of 0.01: " << s.restarts << " restarts, amplitude measured at " << measured
            << " steps; post-momentum energy " << post << ", energy of p~ " << energy << ", error at t = 10^4 "
            << error << " (distance travelled " << centre.norm() << ")\n";
  EXPECT_LE(post, 1e-12);
  EXPECT_LE(energy, 1e-3);
  EXPECT_LE(error, 1.0) << "the plain method is 1e4 off here";
  EXPECT_GT(s.restarts, 10);
  EXPECT_LT(s.restarts, 1000) << "a trigger relative to |lambda_s| would fire at almost every step";
  EXPECT_LT(measured, 250000) << "the measurement is spaced out while the mode is small";
}

// Auto with the default tolerance: an amplitude above it at the step after each of two
// restarts in a row is a floor that restarts cannot remove (a million-body chain's gap
// round-off); later restarts fire only above twice it (twice the larger of the two), and a
// higher one after two more restarts raises it. After one restart it is not yet a floor: a
// step can excite the mode afresh (a chain passing a configuration where its one-forms become
// dependent), and the second restart removes that. A measurement that does not follow a
// restart sets no floor, and a tolerance the user set is kept.
TEST(AutoRestart, AFloorAfterTwoRestartsRaisesOnlyTheDefaultTolerance) {
  using detail::plan_after_measurement;
  using detail::plan_after_restart;
  const double h = 0.01, tol = h * h * h;
  RestartOptions o;
  ModeWatch w;
  EXPECT_TRUE(plan_after_measurement(o, h, w, 10, 5 * tol));
  EXPECT_EQ(w.floor, 0.0) << "not right after a restart";
  plan_after_restart(o, w, 10);
  EXPECT_TRUE(plan_after_measurement(o, h, w, 11, 2.5 * tol)) << "one restart is no proof: restart again";
  EXPECT_EQ(w.floor, 0.0);
  plan_after_restart(o, w, 11);
  EXPECT_FALSE(plan_after_measurement(o, h, w, 12, 3 * tol)) << "the floor itself";
  EXPECT_EQ(w.floor, 3 * tol);
  EXPECT_FALSE(plan_after_measurement(o, h, w, w.last_step + 1, 3.3 * tol));
  EXPECT_EQ(w.next_step - w.last_step, 6) << "growth 1.1 from 3.3 to twice the floor: log(6/3.3)/log(1.1)";
  EXPECT_FALSE(plan_after_measurement(o, h, w, w.next_step, 5.9 * tol));
  EXPECT_TRUE(plan_after_measurement(o, h, w, w.next_step, 6.1 * tol));
  const long now = w.last_step;
  plan_after_restart(o, w, now);
  EXPECT_FALSE(plan_after_measurement(o, h, w, now + 1, 4 * tol)) << "below twice the floor: kept";
  EXPECT_EQ(w.floor, 3 * tol);
  plan_after_restart(o, w, now + 1);
  EXPECT_TRUE(plan_after_measurement(o, h, w, now + 2, 7 * tol)) << "above it once: restart again";
  EXPECT_EQ(w.floor, 3 * tol);
  plan_after_restart(o, w, now + 2);
  EXPECT_FALSE(plan_after_measurement(o, h, w, now + 3, 6.5 * tol)) << "above it twice: the new floor";
  EXPECT_NEAR(w.floor, 7 * tol, 1e-16) << "the larger of the two (kept as -1 - a: to 1e-16)";
  EXPECT_FALSE(plan_after_measurement(o, h, w, now + 10, 7 * tol)) << "no restart two steps on either";

  // A mode excited by one step: the second restart removes it, and no floor is set.
  ModeWatch u;
  plan_after_restart(o, u, 20);
  EXPECT_TRUE(plan_after_measurement(o, h, u, 21, 2e4 * tol));
  plan_after_restart(o, u, 21);
  EXPECT_FALSE(plan_after_measurement(o, h, u, 22, 0.1 * tol));
  EXPECT_EQ(u.floor, 0.0);
  // A periodic restart in between is a plain restart, not a probe.
  plan_after_restart(o, u, 23);
  EXPECT_EQ(u.last_amplitude, -1.0);

  RestartOptions user;
  user.tolerance = tol;
  ModeWatch v;
  for (long k = 10; k < 13; ++k) {  // each restart followed by the same amplitude: no floor
    plan_after_restart(user, v, k);
    EXPECT_TRUE(plan_after_measurement(user, h, v, k + 1, 3 * tol));
  }
  EXPECT_EQ(v.floor, 0.0);
}

// Long runs that the plain method cannot finish, or finishes wrong, end ok with the defaults.
TEST(AutoRestart, LongRunsEndOkWithTheDefaults) {
  struct Case {
    const char* scene;
    std::vector<std::string> sets;
    double t_end;
  };
  for (const Case& c : {Case{"sleigh_chain", {"bodies=100"}, 1000.0}, Case{"snakeboard", {}, 1000.0},
                        Case{"wheeled_train", {"bodies=200"}, 100.0}}) {
    scenarios::RunConfig config;
    config.scene = c.scene;
    config.assignments = c.sets;
    config.t_end = c.t_end;
    const scenarios::RunSummary r = scenarios::run_scene(config);
    std::cout << r.line() << "\n";
    EXPECT_EQ(r.status, Status::Ok) << r.message;
    EXPECT_NEAR(r.t_final, c.t_end, 1e-6);
    EXPECT_LE(r.gap_max, 1e-10);
    EXPECT_LE(r.parasitic_max, 1e-4) << c.scene;
    EXPECT_TRUE(r.warning.empty()) << r.warning;
    // The train's companion at 2 dt fails on its own period-2 mode at t = 86.74 and starts again
    // from the run's state: still the companion's estimate, no warning.
    EXPECT_EQ(r.accuracy_check, "companion") << c.scene;
  }
}

}  // namespace
}  // namespace nonholo
