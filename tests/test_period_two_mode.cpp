// The period-2 ("parasitic") mode of the two-step scheme. The post-momenta alternate
// about p~ by (h/2) mu^T lambda~; besides its smooth part, lambda~ can carry a component
// that flips sign every step. For a reversible two-step method that component follows the
// time-reversed linearisation of the flow, so where the continuous motion is attracting it
// grows: on the sleigh, whose straight motion attracts at the rate kappa = a m c / J
// (docs/design.md section 6), it grows like exp(kappa t) from a seed of order h^3, until it holds
// a large share of the kinetic energy (the post-momentum energy stays exact throughout).
// These tests pin that behaviour of the plain method (RestartMode::Never) down so that any
// change to it is seen; test_restart.cpp tests the remedy.
#include <nonholo/diagnostics.hpp>
#include <nonholo/rattle.hpp>
#include <nonholo/scenarios/scene.hpp>
#include <nonholo/start.hpp>

#include <gtest/gtest.h>

#include <cmath>
#include <iostream>
#include <vector>

namespace nonholo {
namespace {

// |h (lambda~_{k+1} - 2 lambda~_k + lambda~_{k-1}) / 4|: the smooth part of lambda~ drops out
// to O(h^3), the alternating part is kept (times h: a momentum).
struct Sample {
  double t;
  double amplitude;
  double energy_share;  // (E_post - E(p~)) / E_post: the mode's share of the energy
};

// The paper's plain method (restart "0") unless a restart policy is given.
std::vector<Sample> sleigh_mode(double h, double t_end, double every, const char* restart = "0") {
  const auto& info = scenarios::find_scene("sleigh");
  auto setup = info.build(info.defaults());
  Workspace ws(setup.model);
  State s = start_from_velocity(setup.model, ws, 0.0, setup.q0, setup.v0);
  Vector older = s.lambda, old = s.lambda;
  std::vector<Sample> out;
  const long steps = std::lround(t_end / h), stride = std::lround(every / h);
  RattleOptions options;
  options.h = h;
  set_restart(options.restart, restart);
  for (long k = 1; k <= steps; ++k) {
    EXPECT_EQ(step(setup.model, ws, s, options), Status::Ok);
    if (k % stride == 0) {
      const Diagnostics d = diagnose(setup.model, ws, s, h);
      out.push_back({s.t, std::abs(h * (s.lambda[0] - 2 * old[0] + older[0]) / 4),
                     (d.energy_post - d.energy) / d.energy_post});
    }
    older = old;
    old = s.lambda;
  }
  return out;
}

TEST(PeriodTwoMode, SleighGrowthRateIsTheContractionRateOfTheFlow) {
  // Defaults m = I = 1, a = 0.2, v0 = omega0 = 1: J = 1.04, c = sqrt(2.04), kappa = 0.27467.
  const double kappa = 0.2 * std::sqrt(1.0 + 1.04) / 1.04;
  const auto samples = sleigh_mode(0.01, 40.0, 5.0);
  // Between t = 15 and 35 the sleigh is nearly straight (v close to c) and the mode is still
  // far too small to act back on the motion.
  const Sample& a = samples[2];
  const Sample& b = samples[6];
  ASSERT_NEAR(a.t, 15.0, 1e-9);
  ASSERT_NEAR(b.t, 35.0, 1e-9);
  const double rate = std::log(b.amplitude / a.amplitude) / (b.t - a.t);
  std::cout << "sleigh period-2 mode: growth rate " << rate << " (kappa = " << kappa << "), amplitude "
            << a.amplitude << " at t = 15, " << b.amplitude << " at t = 35\n";
  EXPECT_NEAR(rate, kappa, 0.02 * kappa);
}

TEST(PeriodTwoMode, SleighSeedIsThirdOrderInTheStep) {
  const double coarse = sleigh_mode(0.01, 10.0, 10.0).back().amplitude;
  const double fine = sleigh_mode(0.005, 10.0, 10.0).back().amplitude;
  std::cout << "sleigh period-2 mode at t = 10: " << coarse << " (h = 0.01), " << fine
            << " (h = 0.005), ratio " << coarse / fine << "\n";
  EXPECT_NEAR(coarse / fine, 8.0, 0.8);
}

TEST(PeriodTwoMode, SleighModeTakesEnergyAndGivesItBack) {
  // With h = 0.01 the mode reaches O(1) near t = 60 and for a while holds nearly all of the
  // kinetic energy (measured peak share 0.9997), then returns it: an exchange, not a
  // blow-up (the post-momentum energy stays exact).
  double peak = 0.0, last = 1.0;
  for (const Sample& s : sleigh_mode(0.01, 120.0, 1.0)) {
    peak = std::max(peak, s.energy_share);
    last = s.energy_share;
  }
  std::cout << "sleigh period-2 mode, h = 0.01: peak energy share " << peak << ", at t = 120 " << last << "\n";
  EXPECT_GT(peak, 0.2);
  EXPECT_LT(last, 1e-3);
}

TEST(PeriodTwoMode, MultiplierRestartsKeepTheModeAtItsSeed) {
  // Restarting lambda~ from the continuous multiplier every 100 steps (1 time unit) removes
  // the mode's accumulated growth: to t = 80, where the plain method's mode reaches O(1), it
  // stays below what the plain method carries at t = 10 (its seed, 1.2e-6). The energy
  // share then stays at its floor from the smooth multiplier alone: E_post - E(p~) =
  // (h^2/8) lambda^T C lambda, here (1e-4/8)(1.04)(0.96^2)/1.02, about 1.2e-5 at t = 0.
  double plain = 0.0, restarted = 0.0, share = 0.0;
  const double seed = sleigh_mode(0.01, 10.0, 10.0).back().amplitude;
  for (const Sample& s : sleigh_mode(0.01, 80.0, 1.0)) plain = std::max(plain, s.amplitude);
  for (const Sample& s : sleigh_mode(0.01, 80.0, 1.0, "100")) {
    restarted = std::max(restarted, s.amplitude);
    share = std::max(share, std::abs(s.energy_share));
  }
  std::cout << "sleigh period-2 mode to t = 80, h = 0.01: max amplitude " << plain << " plain, "
            << restarted << " with restarts every 100 steps (plain at t = 10: " << seed
            << "; max energy share with restarts " << share << ")\n";
  EXPECT_GT(plain, 1e-2);
  EXPECT_LT(restarted, seed);
  EXPECT_LT(share, 2.5e-5);
}

}  // namespace
}  // namespace nonholo
