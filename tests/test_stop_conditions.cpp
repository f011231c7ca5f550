// Stop conditions (RunConfig::stop_when, stop_conditions; docs/guide/command-line.md "Stop
// conditions"): the crossing time found on the interpolant against exact ones (the particle's y
// and the bladeless sleigh's heading move uniformly, so the method's own are exact to round-off),
// the output kept to the step that saw it, a checkpoint resumed to the same stop bit for bit, a
// condition that throws or already holds, and the refusals.
#include <nonholo/scenarios/command_line.hpp>
#include <nonholo/scenarios/run.hpp>

#include "support/expect_error.hpp"
#include "support/run_cli.hpp"
#include "support/temp_files.hpp"

#include <gtest/gtest.h>

#include <unistd.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace nonholo::scenarios {
namespace {

namespace fs = std::filesystem;
using testing::expect_error;

using testing::bytes_of;

std::string temp(const std::string& name) { return testing::temp_path("stop", name); }

// The sleigh's model at its defaults and a run of it to t = 1 in steps of 0.01.
struct Sleigh {
  SceneSetup setup = find_scene("sleigh").build(find_scene("sleigh").defaults());
  RunConfig config = [] {
    RunConfig c;
    c.dt = 0.01;
    c.t_end = 1.0;
    return c;
  }();
  RunSummary run() const { return run_model(setup.model, {setup.t0, setup.q0, setup.v0, {}}, config); }
};

// The CSV's last row's t.
double last_time(const std::string& csv) {
  std::ifstream in(csv);
  std::string line, last;
  while (std::getline(in, line))
    if (!line.empty()) last = line;
  return std::stod(last.substr(0, last.find(',')));
}

// The particle from (0, 0, 0) with velocity guess (1, 1, 0): y = t exactly (no constraint force
// has a y component), so "y > c" first holds at t = c.
TEST(StopConditions, ACoordinateCrossingIsFoundAtItsExactTime) {
  for (const double c : {0.123456789, 0.5 + 1e-6, 3.0 + 1.0 / 3.0}) {  // off the grid of steps
    std::ostringstream text;
    text.precision(17);
    text << "y>" << c;
    RunConfig config = parse_run_arguments({"particle", "--stop-when", text.str()});
    const RunSummary s = run_scene(config);
    ASSERT_EQ(s.status, Status::Stopped) << s.message;
    EXPECT_EQ(s.stopped_by, text.str());
    EXPECT_NEAR(s.t_stop, c, 1e-13) << "refined on the interpolant";
    // The step that saw it: the first whose end is beyond c.
    EXPECT_EQ(s.steps, static_cast<long>(std::floor(c / 0.01 + 1e-9)) + 1) << c;
    EXPECT_NEAR(s.t_final, 0.01 * static_cast<double>(s.steps), 1e-12);
  }
}

// The sleigh with its blade at the centre (a = 0) turns uniformly: theta = omega0 t. A condition
// in code checked every 7 steps is refined over the 7 steps since its last check.
TEST(StopConditions, AConditionInCodeCheckedEveryFewStepsIsRefinedOverThem) {
  const SceneInfo& info = find_scene("sleigh");
  Parameters p = info.defaults();
  p.assign("a=0");
  p.assign("omega0=0.7");
  const SceneSetup setup = info.build(p);
  RunConfig config;
  config.dt = 0.01;
  config.t_end = 10.0;
  long calls = 0;
  StopCondition turned;
  turned.name = "turned a radian";
  turned.every = 7;
  turned.holds = [&calls](double, ConstVecRef q) {
    ++calls;
    return q[2] > 1.0;
  };
  config.stop_conditions = {turned};
  const RunSummary s = run_model(setup.model, {setup.t0, setup.q0, setup.v0, {}}, config);
  ASSERT_EQ(s.status, Status::Stopped) << s.message;
  EXPECT_EQ(s.stopped_by, "turned_a_radian");
  EXPECT_NEAR(s.t_stop, 1.0 / 0.7, 1e-12);
  EXPECT_EQ(s.steps % 7, 0) << "seen at a check";
  EXPECT_GT(0.01 * static_cast<double>(s.steps), 1.0 / 0.7);
  EXPECT_LE(0.01 * static_cast<double>(s.steps - 7), 1.0 / 0.7);
  EXPECT_LT(calls, s.steps / 7 + 1 + 64) << "checks plus the bisection's";
}

// The output keeps every row up to the step that saw it (that one written whatever --every), the
// summary says which and when, the command line exits 0 and names it on standard error.
TEST(StopConditions, TheOutputEndsAtTheStepThatSawIt) {
  const std::string csv = temp("chain.csv");
  const auto r = nonholo::testing::run_cli({"run", "sleigh_chain", "--set", "omega0=3", "--every", "10",
                                           "--stop-when", "hitch-angle>0.8", "--out", csv});
  EXPECT_EQ(r.code, 0) << r.err;
  const auto kv = nonholo::testing::summary_fields(r.out);
  EXPECT_EQ(kv.at("status"), "stopped");
  EXPECT_EQ(kv.at("stopped_by"), "hitch-angle>0.8");
  EXPECT_NE(r.err.find("stopped by hitch-angle>0.8, which first held at t = "), std::string::npos) << r.err;
  const double t_stop = std::stod(kv.at("t_stop")), t_end = std::stod(kv.at("t_end"));
  EXPECT_GT(t_stop, t_end - 0.01);
  EXPECT_LE(t_stop, t_end);
  EXPECT_EQ(last_time(csv), t_end) << "the step that saw it is written";
  fs::remove(csv);
}

// Stopped by a checkpoint a few steps before the condition holds, then resumed: the same stop,
// the same output bytes, the same summary; a stopped run is not resumed.
TEST(StopConditions, AResumedRunStopsWhereTheWholeOneDid) {
  const std::string whole = temp("whole.csv"), part = temp("part.csv"), checkpoint = temp("ck.h5");
  const std::vector<std::string> args{"sleigh_chain", "--set", "omega0=3", "--stop-when", "hitch-angle>0.8",
                                      "--stop-when", "gap>1"};
  RunConfig full = parse_run_arguments(args);
  full.csv_path = whole;
  const RunSummary expected = run_scene(full);
  ASSERT_EQ(expected.status, Status::Stopped);

  RunConfig first = parse_run_arguments(args);
  first.csv_path = part;
  first.checkpoint_path = checkpoint;
  first.t_end = 0.1;  // before the stop
  ASSERT_EQ(run_scene(first).status, Status::Ok);
  RunConfig resume;
  resume.resume_path = checkpoint;
  resume.t_end = 10.0;
  const RunSummary resumed = run_scene(resume);
  EXPECT_EQ(resumed.status, Status::Stopped) << resumed.message;
  EXPECT_EQ(std::memcmp(&resumed.t_stop, &expected.t_stop, sizeof(double)), 0)
      << resumed.t_stop << " against " << expected.t_stop;
  EXPECT_EQ(resumed.steps, expected.steps);
  EXPECT_EQ(bytes_of(whole), bytes_of(part));
  expect_error([&] { run_scene(resume); }, "the run was stopped by its condition hitch-angle>0.8 at t = ");
  for (const auto& f : {whole, part, checkpoint}) fs::remove(f);
}

TEST(StopConditions, OneThatThrowsFailsTheRunAndOneThatHoldsEndsItAtTheStart) {
  Sleigh sleigh;
  StopCondition throws;
  throws.name = "picky";
  throws.holds = [](double t, ConstVecRef) -> bool {
    if (t > 0.5) throw std::runtime_error("no state after 0.5 is good enough");
    return false;
  };
  sleigh.config.stop_conditions = {throws};
  const RunSummary failed = sleigh.run();
  EXPECT_EQ(failed.status, Status::CallbackFailed);
  EXPECT_NE(failed.message.find("the stop condition picky failed at t = 0.51"), std::string::npos) << failed.message;
  EXPECT_NE(failed.message.find("no state after 0.5 is good enough"), std::string::npos);
  EXPECT_EQ(failed.steps, 51);

  sleigh.config.stop_conditions.clear();
  sleigh.config.stop_when = {"x<1"};  // x0 = 0
  const RunSummary at_start = sleigh.run();
  EXPECT_EQ(at_start.status, Status::Stopped);
  EXPECT_EQ(at_start.steps, 0);
  EXPECT_EQ(at_start.t_stop, 0.0);
}

TEST(StopConditions, RefusesWhatItCannotCheck) {
  auto refused = [](const std::vector<std::string>& args, const std::string& fragment) {
    expect_error([&] { run_scene(parse_run_arguments(args)); }, fragment);
  };
  refused({"sleigh", "--stop-when", "x"}, "--stop-when 'x': give NAME>VALUE or NAME<VALUE");
  refused({"sleigh", "--stop-when", "x>"}, "give NAME>VALUE");
  refused({"sleigh", "--stop-when", "x>1e999"}, "'1e999' is not a finite number");
  refused({"sleigh", "--stop-when", "x>one"}, "'one' is not a finite number");
  refused({"sleigh", "--stop-when", "q7>1"}, "no coordinate 'q7' in the model (its coordinates: x, y, theta");
  refused({"sleigh", "--stop-when", "hitch-angle>1"}, "hitch-angle needs two consecutive planar bodies");
  refused({"sleigh", "--stop-when", "gap>1"}, "gap needs holonomic constraints");
  refused({"sleigh_chain", "--stop-when", "gap<1"}, "give gap>VALUE");
  refused({"sleigh_chain", "--stop-when", "hitch-angle>-1"}, "give a bound of 0 or more");
  Sleigh sleigh;
  StopCondition never;
  never.holds = [](double, ConstVecRef) { return false; };
  never.every = 0;
  sleigh.config.stop_conditions = {never};
  expect_error([&] { sleigh.run(); }, "stop condition condition-0: every = 0 must be at least 1");
}

}  // namespace
}  // namespace nonholo::scenarios
