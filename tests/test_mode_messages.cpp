// The period-2 mode near a configuration where the one-forms become dependent, and the advice
// of the mode's messages. examples/scenes/pivot_chain.json: ten sleighs whose first two blades
// sit on one hitch point and turn through alignment at t = 0.05, where C is singular. Before
// issue 23 the default restarts stopped it there (restart-failed at step 6) while --restart 0
// ran on: the holonomic offset dlambda/2 of the gap correction, taken through mu(q_{k+1})
// instead of the step's own mu(q_k), read as a mode of 1.2 where there was 0.02, and the
// restart built on it could not keep the energy.
#include <nonholo/rattle.hpp>
#include <nonholo/scenarios/run.hpp>
#include <nonholo/scenarios/scene_file.hpp>
#include <nonholo/start.hpp>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

namespace nonholo {
namespace {

using ::testing::HasSubstr;
using ::testing::IsEmpty;
using ::testing::Not;

const std::string kPivotChain = std::string(NONHOLO_SOURCE_DIR) + "/examples/scenes/pivot_chain.json";

scenarios::RunSummary run(const std::string& scene, std::vector<std::string> sets, const std::string& restart,
                          double dt, double t_end) {
  scenarios::RunConfig c;
  c.scene = scene;
  c.assignments = std::move(sets);
  c.restart = restart;
  c.dt = dt;
  c.t_end = t_end;
  return scenarios::run_scene(c);
}

// The measured amplitude against an independent one: the mode alternates the step's
// displacement, so a quarter of the third difference of q, relative to |q_{k+1} - q_k|, is
// its size (plus an O(h^2) smooth part). Measured at every step of the plain method across the
// crossing, the two must agree within a factor 2 (before the fix: 1.23 against 0.039).
TEST(PivotChain, TheMeasuredModeIsTheOneInTheTrajectory) {
  const auto info = scenarios::load_scene_file(kPivotChain);
  const auto setup = info.build(info.defaults());
  const Model& model = setup.model;
  Workspace ws(model);
  State s = start_from_velocity(model, ws, setup.t0, setup.q0, setup.v0);
  RattleOptions o;
  o.h = 0.01;
  set_restart(o.restart, "0");
  o.restart.monitor_every = 1;
  std::vector<Vector> q{s.q};
  double measured = 0.0, independent = 0.0;
  for (int k = 1; k <= 30; ++k) {
    ASSERT_EQ(step(model, ws, s, o), Status::Ok) << ws.message();
    if (k > 1) measured = std::max(measured, ws.parasitic);
    q.push_back(s.q);
    if (k >= 3) {
      const Vector d3 = q[k] - 3.0 * q[k - 1] + 3.0 * q[k - 2] - q[k - 3];
      independent = std::max(independent, 0.25 * d3.norm() / (q[k] - q[k - 1]).norm());
    }
  }
  EXPECT_GT(independent, 0.02) << "the crossing excites a real mode";
  EXPECT_LT(measured, 2.0 * independent);
  EXPECT_GT(measured, 0.5 * independent);
}

// With the default restarts the chain passes the singular configuration and runs to the end,
// no worse than the plain method.
TEST(PivotChain, DefaultRestartsPassTheSingularConfiguration) {
  const auto defaults = run(kPivotChain, {}, "auto", 0.0, 10.0);
  EXPECT_EQ(defaults.status, Status::Ok) << defaults.message;
  EXPECT_EQ(defaults.steps, 1000);
  const auto plain = run(kPivotChain, {}, "0", 0.0, 10.0);
  EXPECT_EQ(plain.status, Status::Ok) << plain.message;
  EXPECT_LT(defaults.parasitic_max, plain.parasitic_max);
}

// Each warning of the mode, followed: the run then ends without it (or, where a run stops,
// gets further).
TEST(ModeMessages, TheAdviceOfEachWarningWorks) {
  // Auto: "reduce --dt". The pivot chain's crossing at dt = 0.01 leaves a mode of 0.02; at 0.001
  // restarts hold it below the warning.
  const auto coarse = run(kPivotChain, {}, "auto", 0.01, 2.0);
  EXPECT_EQ(coarse.status, Status::Ok);
  EXPECT_THAT(coarse.warning, HasSubstr("reduce --dt"));
  EXPECT_THAT(coarse.warning, Not(HasSubstr("--monitor-every"))) << "measuring every step did not help (0.0203 either way)";
  const auto fine = run(kPivotChain, {}, "auto", 0.001, 2.0);
  EXPECT_EQ(fine.status, Status::Ok);
  EXPECT_THAT(fine.warning, IsEmpty());
  EXPECT_LT(fine.parasitic_max, 1e-3);

  // Without restarts: "use --restart auto". The sleigh's mode reaches O(1) near t = 60.
  // (77 off at t = 100: the accuracy check ends it inaccurate, the warning says why.)
  const auto plain = run("sleigh", {}, "0", 0.0, 100.0);
  EXPECT_EQ(plain.status, Status::Inaccurate);
  EXPECT_THAT(plain.warning, HasSubstr("--restart auto"));
  const auto restarted = run("sleigh", {}, "auto", 0.0, 100.0);
  EXPECT_EQ(restarted.status, Status::Ok);
  EXPECT_THAT(restarted.warning, IsEmpty());
}

// A speed the step cannot follow (issue 23): a sleigh at v0 = 1e4 damps its turn at m a v /
// (I + m a^2) = 1900/s; at dt = 0.01 the discrete turn reached 8000 rad/s and the mode read 21.9
// of |p~| (p~ turned, the post-momentum kept its energy). The warning must name the cause and a dt
// that works, and following it must end without the warning.
TEST(ModeMessages, ASpeedTooLargeForTheStepNamesADtThatWorks) {
  const auto coarse = run("sleigh", {"v0=1e4"}, "auto", 0.01, 1.0);
  EXPECT_THAT(coarse.warning, HasSubstr("turn rate"));
  const auto at = coarse.warning.find("use --dt ");
  ASSERT_NE(at, std::string::npos) << coarse.warning;
  const double dt = std::stod(coarse.warning.substr(at + 9));
  EXPECT_LT(dt, 1e-3);  // 5e-4 is where the turn's damping h m a v / (I + m a^2) passes 1
  const auto fine = run("sleigh", {"v0=1e4"}, "auto", dt, 1.0);
  EXPECT_EQ(fine.status, Status::Ok);
  EXPECT_THAT(fine.warning, IsEmpty());
  EXPECT_LT(fine.energy_rel_err_max, 1e-6);
}

// A body at rest (issue 23): a disk standing upright under gravity has p~ = 0 and energy 0 to
// round-off. The energy error compared round-off with round-off (1, and blew-up at step 2) and
// the mode's amplitude divided by |p~| ~ 1e-18 (3, with two restarts).
TEST(ModeMessages, ABodyAtRestReportsNoChange) {
  for (const char* restart : {"auto", "0"}) {
    const auto r = run("rolling_disk", {"Omega1=0", "Omega2=0", "Omega3=0"}, restart, 0.0, 1.0);
    EXPECT_EQ(r.status, Status::Ok) << restart << ": " << r.message;
    EXPECT_LT(r.energy_balance_err_max, 1e-10) << restart;
    EXPECT_LT(r.energy_rel_err_max, 1e-10) << restart;
    EXPECT_LT(r.parasitic_max, 1e-12) << restart;
    EXPECT_EQ(r.restarts, 0) << restart;
    EXPECT_THAT(r.warning, IsEmpty()) << restart;
  }
}

// A tiny step (issue 23): with the default tolerance h^3 = 1e-27 at h = 1e-9, below the
// amplitude's round-off (a few eps), every measurement restarted: 10^4 restarts in 10^4 steps on
// the sleigh and the snakeboard. With the floor RestartOptions::kRoundOff none is needed.
TEST(ModeMessages, ATinyStepRestartsOnlyAboveRoundOff) {
  for (const char* scene : {"sleigh", "snakeboard", "particle"}) {
    const auto r = run(scene, {}, "auto", 1e-9, 1e-5);
    EXPECT_EQ(r.status, Status::Ok) << scene;
    EXPECT_LT(r.restarts, 10) << scene;
    EXPECT_LT(r.parasitic_max, 1e-13) << scene;  // a few eps
    EXPECT_THAT(r.warning, IsEmpty()) << scene;
  }
}

// A tiny step with holonomic hitches (issue 23): each step closes the hitch gaps that the
// round-off of the coordinates leaves (16 eps |q| = 3.5e-12 on the 1000-unit train), a velocity
// kick 2 g / dt that no smaller step removes (dt = 1e-8: the mode at 0.011, and the warning said
// "reduce --dt"). The warning must say so and name what works: --hitch oneform, or the dt it names.
TEST(ModeMessages, GapCorrectionsOfATinyStepNameWhatWorks) {
  const double t_end = 1e-4;
  const auto tiny = run("wheeled_train", {}, "auto", 1e-8, t_end);
  EXPECT_EQ(tiny.status, Status::Ok) << tiny.message;
  EXPECT_GT(tiny.parasitic_max, 1e-3);
  EXPECT_THAT(tiny.warning, HasSubstr("gap corrections dominate"));
  EXPECT_THAT(tiny.warning, Not(HasSubstr("reduce --dt")));
  const auto at = tiny.warning.find("or --dt ");
  ASSERT_NE(at, std::string::npos) << tiny.warning;
  const double dt = std::stod(tiny.warning.substr(at + 8));
  EXPECT_GT(dt, 1e-8);
  EXPECT_LT(dt, 1e-6);
  const auto longer = run("wheeled_train", {}, "auto", dt, t_end);
  EXPECT_EQ(longer.status, Status::Ok) << longer.message;
  EXPECT_THAT(longer.warning, IsEmpty());
  EXPECT_LT(longer.parasitic_max, 1e-3);

  scenarios::RunConfig c;
  c.scene = "wheeled_train";
  c.dt = 1e-8;
  c.t_end = t_end;
  c.hitch = HitchMode::OneForm;
  const auto oneform = scenarios::run_scene(c);
  EXPECT_EQ(oneform.status, Status::Ok) << oneform.message;
  EXPECT_THAT(oneform.warning, IsEmpty());
  EXPECT_LT(oneform.parasitic_max, 1e-12);
}

}  // namespace
}  // namespace nonholo
