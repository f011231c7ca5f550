// No run ends with status=ok when its result is wrong, non-finite or blown up: the stiffest
// frequency against exact values, the stability limit refused and warned about, overflowing
// starts, energy blow-ups, failed batch trajectories, and coordinates too large for a hitch
// (test_run_bounds.cpp: the bounds every method and order is held to).
#include <nonholo/model_builder.hpp>
#include <nonholo/stability.hpp>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <map>
#include <sstream>

#include "support/run_cli.hpp"

namespace nonholo {
namespace {

using ::testing::HasSubstr;
using testing::run_cli;

std::map<std::string, std::string> summary_of(const std::string& line) {
  std::map<std::string, std::string> kv;
  std::istringstream in(line);
  std::string field;
  while (in >> field)
    if (const auto eq = field.find('='); eq != std::string::npos) kv[field.substr(0, eq)] = field.substr(eq + 1);
  return kv;
}

// N rotors theta_i (inertia I) joined by springs k (theta_i - theta_{i+1})^2 / 2: the largest
// frequency is 2 sqrt(k / I) sin((N - 1) pi / (2N)). Optionally each rotor is a planar body
// with a knife edge (theta is not constrained by it, so the frequencies stay the same).
Model rotor_chain(int n, double k, double inertia) {
  ModelBuilder b;
  for (int i = 0; i < n; ++i) b.add_planar_body({"x" + std::to_string(i), "y" + std::to_string(i), "t" + std::to_string(i)}, 1.0, inertia);
  for (int i = 0; i < n; ++i) b.add_one_form({3 * i, 3 * i + 1});
  b.one_form_values([n](ConstVecRef q, VecRef mu) {
    for (int i = 0; i < n; ++i) {
      mu[2 * i] = -std::sin(q[3 * i + 2]);
      mu[2 * i + 1] = std::cos(q[3 * i + 2]);
    }
  });
  b.potential(
      [n, k](ConstVecRef q) {
        double v = 0.0;
        for (int i = 0; i + 1 < n; ++i) v += 0.5 * k * std::pow(q[3 * i + 2] - q[3 * i + 5], 2);
        return v;
      },
      [n, k](ConstVecRef q, VecRef g) {
        g.setZero();
        for (int i = 0; i + 1 < n; ++i) {
          const double s = k * (q[3 * i + 2] - q[3 * i + 5]);
          g[3 * i + 2] += s;
          g[3 * i + 5] -= s;
        }
      });
  return b.build();
}

TEST(Stability, StiffestFrequencyMatchesTheExactOne) {
  for (int n : {2, 5, 12}) {
    const double k = 1e4, inertia = 0.5;
    const Model model = rotor_chain(n, k, inertia);
    Workspace ws(model);
    const Vector q = Vector::Zero(3 * n);
    const StiffnessEstimate e = stiffest_frequency(model, ws, 0.0, q, nullptr, 400, 1e-10);
    const double exact = 2.0 * std::sqrt(k / inertia) * std::sin((n - 1) * M_PI / (2.0 * n));
    EXPECT_LE(e.omega, exact * (1 + 1e-6)) << "a lower bound, n = " << n;
    EXPECT_NEAR(e.omega, exact, 1e-3 * exact) << "n = " << n;
    EXPECT_DOUBLE_EQ(stability_limit(e.omega), 2.0 / e.omega);
  }
}

// A stiff spring along x on a particle that cannot move along x: the constrained motion has
// only the soft spring along y, and the estimate must see the projection.
TEST(Stability, ConstraintsRemoveTheirStiffDirections) {
  ModelBuilder b;
  b.add_body({"x", "y"}, Eigen::Matrix2d::Identity());
  b.add_one_form({0});
  b.one_form_values([](ConstVecRef, VecRef mu) { mu[0] = 1.0; });
  b.potential([](ConstVecRef q) { return 0.5 * 1e8 * q[0] * q[0] + 0.5 * 4.0 * q[1] * q[1]; },
              [](ConstVecRef q, VecRef g) { g << 1e8 * q[0], 4.0 * q[1]; });
  const Model model = b.build();
  Workspace ws(model);
  const StiffnessEstimate e = stiffest_frequency(model, ws, 0.0, Eigen::Vector2d(0.1, 0.2));
  EXPECT_NEAR(e.omega, 2.0, 1e-6);
  // Without forces there is nothing to limit the step.
  ModelBuilder free_body;
  free_body.add_planar_body({"x", "y", "theta"}, 1.0, 1.0);
  const Model none = free_body.build();
  Workspace wn(none);
  EXPECT_EQ(stiffest_frequency(none, wn, 0.0, Vector::Zero(3)).omega, 0.0);
  EXPECT_TRUE(std::isinf(stability_limit(0.0)));
}

TEST(RunChecks, StepBeyondTheStabilityLimitIsRefused) {
  // k = 1e6 at dt = 0.01: h omega = 19.7 (this blew up to a residual of 5e238 with status=ok).
  const auto r = run_cli({"run", "sleigh_chain", "--set", "k=1e6", "--set", "hitched=0"});
  EXPECT_EQ(r.code, 2);
  const auto kv = summary_of(r.out);
  EXPECT_EQ(kv.at("status"), "unstable-step-size");
  EXPECT_EQ(kv.at("steps"), "0");
  EXPECT_GT(std::stod(kv.at("stability_ratio")), 9.0);
  EXPECT_THAT(r.err, HasSubstr("times the stability limit"));
  EXPECT_THAT(r.err, HasSubstr("use --dt"));
  // The composed orders have their own, wider limit per step; RK4 its 2 sqrt(2).
  for (const char* method : {"rk4"})
    EXPECT_EQ(summary_of(run_cli({"run", "sleigh_chain", "--set", "k=1e6", "--set", "hitched=0", "--method", method}).out)
                  .at("status"),
              "unstable-step-size");
}

TEST(RunChecks, StiffButStableStepIsWarnedAbout) {
  // k = 1e4 at dt = 0.01: stable (h omega = 1.97 < 2) but 3 steps per period.
  auto r = run_cli({"run", "sleigh_chain", "--set", "k=1e4", "--set", "hitched=0", "--t-end", "1"});
  EXPECT_EQ(r.code, 0) << r.err;
  auto kv = summary_of(r.out);
  EXPECT_EQ(kv.at("status"), "ok");
  const double ratio = std::stod(kv.at("stability_ratio"));
  EXPECT_GT(ratio, 0.9);
  EXPECT_LT(ratio, 1.0);
  EXPECT_THAT(r.err, HasSubstr("of the reflection step's stability limit"));
  // Ten times smaller: no warning, a tenth of the ratio.
  r = run_cli({"run", "sleigh_chain", "--set", "k=1e4", "--set", "hitched=0", "--t-end", "1", "--dt", "0.001"});
  EXPECT_EQ(r.code, 0);
  kv = summary_of(r.out);
  EXPECT_NEAR(std::stod(kv.at("stability_ratio")), 0.1 * ratio, 0.01 * ratio);
  EXPECT_THAT(r.err, ::testing::Not(HasSubstr("stability limit")));
  // No forces, no limit: the key is absent.
  EXPECT_EQ(summary_of(run_cli({"run", "sleigh"}).out).count("stability_ratio"), 0u);
}

TEST(RunChecks, OverflowingStartIsRefused) {
  const auto r = run_cli({"run", "sleigh", "--set", "v0=1e200"});
  EXPECT_EQ(r.code, 2);
  EXPECT_EQ(summary_of(r.out).at("status"), "non-finite-state");
  EXPECT_THAT(r.err, HasSubstr("the initial state is out of range: energy inf"));
  // The forces out of range, the state not: the message named the initial velocities.
  const auto forced = run_cli({"run", "wheeled_train", "--set", "bodies=5", "--set", "force=1e200"});
  EXPECT_EQ(forced.code, 2);
  EXPECT_EQ(summary_of(forced.out).at("status"), "non-finite-state");
  EXPECT_THAT(forced.err, HasSubstr("the applied forces are out of range at the start: energy 0.246"));
  EXPECT_THAT(forced.err, HasSubstr("reduce the forces, or choose units that bring them nearer 1"));
  // A state whose step overflows in the restart's arithmetic (v0 = 1e100: the constraint forces
  // grow as the speed squared): it advised "restart less often or not at all".
  const auto fast = run_cli({"run", "sleigh", "--set", "v0=1e100"});
  EXPECT_EQ(fast.code, 2);
  EXPECT_THAT(fast.err, HasSubstr("restart-failed: the restart's arithmetic overflowed (post-momentum energy 5e+199"));
  EXPECT_THAT(fast.err, HasSubstr("reduce the step size by orders of magnitude, or choose units"));
  EXPECT_THAT(fast.err, ::testing::Not(HasSubstr("restart less often")));
}

TEST(RunChecks, EnergyBlowUpStopsTheRun) {
  // The DLA baselines have no stability watch: their blow-up is caught by the energy.
  const auto r = run_cli({"run", "sleigh_chain", "--set", "k=1e6", "--set", "hitched=0", "--method", "dla-midpoint"});
  EXPECT_EQ(r.code, 2);
  const auto kv = summary_of(r.out);
  EXPECT_EQ(kv.at("status"), "blew-up");
  EXPECT_GT(std::stod(kv.at("energy_rel_err_max")), 1.0);
  EXPECT_THAT(r.err, HasSubstr("the trajectory blew up"));
}

TEST(RunChecks, BatchNeverHidesAFailedTrajectory) {
  // Half the stiffnesses are beyond the limit: those fail, the others run, the summary says so.
  const auto r = run_cli({"batch", "sleigh_chain", "--count", "8", "--set", "hitched=0", "--vary", "k=1:1.6e4", "--t-end",
                          "0.5", "--threads", "2"});
  EXPECT_EQ(r.code, 2);
  const auto kv = summary_of(r.out);
  EXPECT_NE(kv.at("status"), "ok");
  EXPECT_NE(kv.at("failed"), "0");
  EXPECT_NE(kv.at("failed"), "8");
  EXPECT_THAT(r.err, HasSubstr("trajectories failed; first: trajectory"));
}

// Times are t0 + k dt: 1e5 steps of 0.1 end at 10000 exactly (summing gives 10000.000000018848).
TEST(RunChecks, TimesAreNotSummed) {
  const std::string csv = ::testing::TempDir() + "times.csv";
  const auto r = run_cli({"run", "sleigh", "--dt", "0.1", "--t-end", "10000", "--every", "100000", "--out", csv});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(summary_of(r.out).at("t_end"), "10000");
  std::ifstream in(csv);
  std::string line, last;
  while (std::getline(in, line)) last = line;
  EXPECT_EQ(last.substr(0, last.find(',')), "10000");
  std::remove(csv.c_str());
}

TEST(RunChecks, CoordinatesTooLargeForAHitchAreNamed) {
  // At rest: no step to lose (moving, it is refused before its first step: test_run_bounds.cpp).
  const std::string path = ::testing::TempDir() + "far_away.json";
  std::ofstream(path) << R"({"bodies": [
      {"mass": 1, "inertia": 1, "position": [1e19, 0], "velocity": [0, 0]},
      {"mass": 1, "inertia": 1, "position": [1e19, 0]}],
    "constraints": [{"type": "knife_edge", "body": 0, "offset": 0.2},
      {"type": "hitch", "bodies": [0, 1], "rear": 0, "front": 0}]})";
  const auto r = run_cli({"run", path});
  EXPECT_EQ(r.code, 2);
  EXPECT_EQ(summary_of(r.out).at("status"), "gap-not-converged");
  EXPECT_THAT(r.err, HasSubstr("exceeds gap_tolerance_limit"));
  std::remove(path.c_str());
}

}  // namespace
}  // namespace nonholo
