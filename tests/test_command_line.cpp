// `nonholo run`, driven in-process: the summary line, the CSV (header, rows, every digit),
// and a clear message plus a non-zero exit for every kind of bad input.
#include <nonholo/rattle.hpp>
#include <nonholo/scenarios/command_line.hpp>
#include <nonholo/scenarios/exact_solutions.hpp>
#include <nonholo/scenarios/scene.hpp>
#include <nonholo/start.hpp>
#include <nonholo/version.hpp>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

#include "support/run_cli.hpp"

namespace nonholo {
namespace {

using ::testing::HasSubstr;
using ::testing::StartsWith;

using Result = testing::CliResult;

Result run(std::vector<std::string> args) { return testing::run_cli(std::move(args)); }

std::map<std::string, std::string> parse_summary(const std::string& line) {
  std::map<std::string, std::string> kv;
  std::istringstream is(line);
  std::string token;
  while (is >> token) {
    const auto eq = token.find('=');
    EXPECT_NE(eq, std::string::npos) << token;
    kv[token.substr(0, eq)] = token.substr(eq + 1);
  }
  return kv;
}

std::string temp_path(const std::string& name) {
  return (std::filesystem::temp_directory_path() / ("nonholo_test_" + std::to_string(::getpid()) + "_" + name)).string();
}

TEST(CommandLine, SummaryLineHasTheRequiredKeys) {
  for (const char* scene : {"particle", "sleigh", "snakeboard"}) {
    const Result r = run({"run", scene});
    ASSERT_EQ(r.code, 0) << r.err;
    EXPECT_EQ(std::count(r.out.begin(), r.out.end(), '\n'), 1) << "exactly one line";
    const auto kv = parse_summary(r.out);
    for (const char* key : {"scene", "steps", "wall_s", "ns_per_step", "energy_rel_err_max",
                            "energy_post_rel_err_max", "residual_max", "backend"})
      EXPECT_TRUE(kv.count(key)) << scene << " lacks " << key;
    EXPECT_EQ(kv.at("scene"), scene);
    EXPECT_EQ(kv.at("steps"), "1000");
    // The sleigh is a knife edge element, streamed; the others' rows come from callbacks.
    EXPECT_EQ(kv.at("backend"), std::string(scene) == "sleigh" ? "banded" : "dense");
    EXPECT_LE(std::stod(kv.at("energy_post_rel_err_max")), 1e-13);
    EXPECT_LE(std::stod(kv.at("residual_max")), 1e-14);
  }
  EXPECT_EQ(parse_summary(run({"run", "sleigh", "--backend", "cholmod-amd"}).out).at("backend"), "cholmod-amd");
}

TEST(CommandLine, ChainSummaryReportsBodiesGapHitchAndBackend) {
  const Result holo = run({"run", "sleigh_chain", "--set", "bodies=20", "--t-end", "1"});
  ASSERT_EQ(holo.code, 0) << holo.err;
  auto kv = parse_summary(holo.out);
  for (const char* key : {"bodies", "ns_per_body_step", "gap_max", "hitch", "restart", "backend"})
    EXPECT_TRUE(kv.count(key)) << "lacks " << key;
  EXPECT_EQ(kv.at("bodies"), "20");
  EXPECT_EQ(kv.at("hitch"), "holonomic");
  EXPECT_EQ(kv.at("restart"), "auto");
  EXPECT_EQ(kv.at("backend"), "banded");
  EXPECT_LE(std::stod(kv.at("gap_max")), 1e-10);
  EXPECT_NEAR(std::stod(kv.at("ns_per_body_step")) * 20, std::stod(kv.at("ns_per_step")),
              1e-3 * std::stod(kv.at("ns_per_step")));

  const Result loose = run({"run", "sleigh_chain", "--set", "bodies=20", "--t-end", "1", "--hitch",
                            "oneform", "--backend", "cholmod-amd", "--restart", "25"});
  ASSERT_EQ(loose.code, 0) << loose.err;
  kv = parse_summary(loose.out);
  EXPECT_EQ(kv.at("hitch"), "oneform");
  EXPECT_EQ(kv.at("restart"), "25");
  EXPECT_EQ(kv.at("backend"), "cholmod-amd");
  EXPECT_GT(std::stod(kv.at("gap_max")), 1e-10) << "one-form hitches drift";

  kv = parse_summary(run({"run", "sleigh_chain", "--set", "hitched=0", "--set", "k=1", "--t-end", "1"}).out);
  EXPECT_EQ(kv.at("backend"), "banded");  // a chain of elements, C diagonal
  EXPECT_EQ(kv.at("gap_max"), "0");
  kv = parse_summary(run({"run", "wheeled_train", "--set", "bodies=30", "--t-end", "1"}).out);
  EXPECT_EQ(kv.at("restart"), "auto") << "every scene's default";
  EXPECT_EQ(kv.at("status"), "ok");
}

TEST(CommandLine, ReferenceMethodsReportTheirWork) {
  for (const char* method : {"rk4", "arkode-dp5", "arkode-verner", "arkode-fehlberg8"}) {
    const Result r = run({"run", "sleigh", "--method", method, "--dt", "0.1", "--t-end", "2"});
    ASSERT_EQ(r.code, 0) << r.err;
    const auto kv = parse_summary(r.out);
    EXPECT_EQ(kv.at("method"), method);
    EXPECT_EQ(kv.at("steps"), "20");
    EXPECT_EQ(kv.at("hitch"), "velocity");
    EXPECT_EQ(kv.at("energy_post_rel_err_max"), "nan") << "no post-momentum";
    EXPECT_GT(std::stol(kv.at("rhs_evals")), 0);
    EXPECT_LT(std::stod(kv.at("energy_rel_err_max")), 1e-5);
  }
  const auto kv = parse_summary(
      run({"run", "sleigh_chain", "--set", "bodies=5", "--method", "rk4", "--project", "--t-end", "1"}).out);
  EXPECT_EQ(kv.at("hitch"), "projected");
  EXPECT_LE(std::stod(kv.at("gap_max")), 1e-12);
  EXPECT_LE(std::stod(kv.at("residual_max")), 1e-14);
  EXPECT_EQ(parse_summary(run({"run", "sleigh"}).out).count("rhs_evals"), 0u);
}

TEST(CommandLine, ChainCsvNamesEveryBodysCoordinates) {
  const std::string path = temp_path("chain.csv");
  ASSERT_EQ(run({"run", "sleigh_chain", "--set", "bodies=3", "--t-end", "0.05", "--out", path}).code, 0);
  std::ifstream in(path);
  std::string header;
  std::getline(in, header);
  EXPECT_EQ(header, "t,x0,y0,theta0,x1,y1,theta1,x2,y2,theta2,energy,energy_post,residual");
  std::remove(path.c_str());
}

TEST(CommandLine, CsvHoldsTheTrajectoryToTheLastDigit) {
  const std::string path = temp_path("sleigh.csv");
  const Result r = run({"run", "sleigh", "--dt", "0.01", "--t-end", "1", "--every", "7", "--out", path,
                        "--set", "a=0.3", "--set", "omega0=2"});
  ASSERT_EQ(r.code, 0) << r.err;
  std::ifstream in(path);
  std::string header;
  std::getline(in, header);
  EXPECT_EQ(header, "t,x,y,theta,energy,energy_post,residual");
  std::vector<std::vector<double>> rows;
  for (std::string line; std::getline(in, line);) {
    std::vector<double> row;
    std::istringstream ls(line);
    for (std::string cell; std::getline(ls, cell, ',');) row.push_back(std::stod(cell));
    ASSERT_EQ(row.size(), 7u) << line;
    rows.push_back(row);
  }
  // Step 0, every 7th of 100 steps, and the last one.
  ASSERT_EQ(rows.size(), 1u + 100 / 7 + 1);
  EXPECT_EQ(rows.front()[0], 0.0);
  EXPECT_DOUBLE_EQ(rows[1][0], 0.07);

  // The same run through the API: the last row must match bit for bit.
  const auto& info = scenarios::find_scene("sleigh");
  scenarios::Parameters p = info.defaults();
  p.assign("a=0.3");
  p.assign("omega0=2");
  auto setup = info.build(p);
  Workspace ws(setup.model);
  State s = start_from_velocity(setup.model, ws, 0.0, setup.q0, setup.v0);
  for (int k = 0; k < 100; ++k) ASSERT_EQ(step(setup.model, ws, s, {0.01}), Status::Ok);
  EXPECT_EQ(rows.back()[0], s.t);
  for (int i = 0; i < 3; ++i) EXPECT_EQ(rows.back()[1 + i], s.q[i]) << "coordinate " << i;
  std::remove(path.c_str());
}

// --tol with a composed order: adaptive steps that land on every output time (--dt). Each CSV
// row against the exact sleigh: the error at t_end within 10 tol (the library's measured
// tracking, test_adaptive), the summary's counts consistent with the factorisations (three
// composed steps a pair, 20 substeps each at order 6).
TEST(CommandLine, AdaptiveStepsLandOnTheOutputTimes) {
  const std::string path = temp_path("adaptive.csv");
  const double tol = 1e-9;
  const Result r = run({"run", "sleigh", "--order", "6", "--tol", "1e-9", "--dt", "0.5", "--t-end", "10", "--out", path});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(r.err, "") << "no warning: the steps are shorter than the output interval";
  const auto kv = parse_summary(r.out);
  EXPECT_EQ(kv.at("steps"), "20");  // output intervals
  EXPECT_EQ(kv.at("tol"), "1e-09");
  const long accepted = std::stol(kv.at("adaptive_steps")), rejected = std::stol(kv.at("rejected"));
  EXPECT_GT(accepted, 20);
  EXPECT_EQ(accepted % 2, 0) << "pairs";
  EXPECT_EQ(std::stol(kv.at("factorizations")), 20 * 3 * (accepted / 2 + rejected) + 1) << "and the start's";
  EXPECT_LE(std::stod(kv.at("energy_rel_err_max")), 1e-14);
  const scenarios::SleighExact exact(1.0, 1.0, 0.2, 1.0, 1.0, 0.0, 0.0, 0.0);
  std::ifstream in(path);
  std::string line;
  std::getline(in, line);
  int rows = 0;
  double error = 0.0;
  for (; std::getline(in, line); ++rows) {
    std::vector<double> row;
    std::istringstream ls(line);
    for (std::string cell; std::getline(ls, cell, ',');) row.push_back(std::stod(cell));
    EXPECT_EQ(row[0], 0.5 * rows) << "lands on the output time exactly";
    const Vector q = exact.configuration(row[0]);
    for (int i = 0; i < 3; ++i) error = std::max(error, std::abs(row[1 + i] - q[i]));
  }
  EXPECT_EQ(rows, 21);
  EXPECT_LT(error, 10 * tol);
  EXPECT_GT(error, 0.1 * tol) << "not far more accurate than asked: the tolerance means something";
  std::remove(path.c_str());
}

// --out -: the CSV on standard output (what a file would hold, to the last digit), the summary
// line on standard error.
TEST(CommandLine, OutDashWritesTheCsvToStandardOutput) {
  const std::string path = temp_path("dash.csv");
  const Result file = run({"run", "sleigh", "--t-end", "0.5", "--out", path});
  ASSERT_EQ(file.code, 0) << file.err;
  std::ifstream in(path);
  std::stringstream csv;
  csv << in.rdbuf();
  ::testing::internal::CaptureStdout();
  const Result dash = run({"run", "sleigh", "--t-end", "0.5", "--out", "-"});
  const std::string printed = ::testing::internal::GetCapturedStdout();
  ASSERT_EQ(dash.code, 0) << dash.err;
  EXPECT_EQ(printed, csv.str());
  EXPECT_EQ(dash.out, "");
  EXPECT_THAT(dash.err, StartsWith("scene=sleigh "));
  std::remove(path.c_str());
}

// One version everywhere: CMakeLists.txt's project(VERSION) in <nonholo/version.hpp>, printed by
// --version with the checkout's revision and the build's target CPU (results differ in the last bits
// between a portable build and -march=...).
TEST(CommandLine, VersionSaysWhichNonholo) {
  const Result r = run({"--version"});
  EXPECT_EQ(r.code, 0);
  EXPECT_EQ(r.out, std::string("nonholo ") + kVersion + " (git " + kGitRevision + ", " + kTargetArch + ")\n");
  EXPECT_EQ(std::string(kVersion), std::to_string(kVersionMajor) + "." + std::to_string(kVersionMinor) + "." +
                                       std::to_string(kVersionPatch));
}

TEST(CommandLine, SnakeboardCsvHeader) {
  const std::string path = temp_path("board.csv");
  ASSERT_EQ(run({"run", "snakeboard", "--t-end", "0.1", "--out", path}).code, 0);
  std::ifstream in(path);
  std::string header;
  std::getline(in, header);
  EXPECT_EQ(header, "t,x,y,theta,psi,phi,energy,energy_post,residual");
  std::remove(path.c_str());
}

void expect_failure(const std::vector<std::string>& args, const std::string& fragment) {
  const Result r = run(args);
  EXPECT_NE(r.code, 0) << "accepted: " << ::testing::PrintToString(args);
  EXPECT_THAT(r.err + r.out, HasSubstr(fragment)) << ::testing::PrintToString(args);
}

// --threads splits a chain's step (WorkspaceOptions::threads) and the summary says how
// many ran: the run agrees with one thread's to round-off; below 2 kBodiesPerThread the default
// is one thread; threads that cannot help are run on one, with a warning.
TEST(CommandLine, ThreadsSplitAChainAndAreReported) {
  const std::vector<std::string> base{"run", "sleigh_chain", "--set", "bodies=40", "--set", "k=2", "--hitch", "oneform"};
  auto with = [&](std::vector<std::string> extra) {
    std::vector<std::string> args = base;
    args.insert(args.end(), extra.begin(), extra.end());
    const Result r = run(args);
    EXPECT_EQ(r.code, 0) << r.err;
    return parse_summary(r.out);
  };
  auto one = with({"--threads", "1"}), four = with({"--threads", "4"}), automatic = with({});
  EXPECT_EQ(one["threads"], "1");
  EXPECT_EQ(four["threads"], "4");
  EXPECT_EQ(automatic["threads"], "1") << "40 bodies are below the automatic threshold";
  EXPECT_EQ(four["status"], "ok");
  for (const char* key : {"energy_rel_err_max", "gap_max", "parasitic_max", "extent"})
    EXPECT_NEAR(std::stod(four[key]), std::stod(one[key]), 1e-6 * std::stod(one[key])) << key;
  EXPECT_EQ(four["restarts"], one["restarts"]);
  // Holonomic hitches (the default) split too, their gaps closed as on one thread.
  const Result holonomic = run({"run", "sleigh_chain", "--set", "bodies=40", "--threads", "2"});
  const Result holonomic_one = run({"run", "sleigh_chain", "--set", "bodies=40", "--threads", "1"});
  EXPECT_EQ(holonomic.code, 0) << holonomic.err;
  EXPECT_THAT(holonomic.err, ::testing::Not(HasSubstr("ran on one thread: threads split")));
  auto h2 = parse_summary(holonomic.out), h1 = parse_summary(holonomic_one.out);
  EXPECT_EQ(h2["threads"], "2");
  EXPECT_EQ(h2["status"], "ok");
  for (const char* key : {"energy_rel_err_max", "extent"})
    EXPECT_NEAR(std::stod(h2[key]), std::stod(h1[key]), 1e-6 * std::stod(h1[key])) << key;
  EXPECT_LE(std::stod(h2["gap_max"]), 1e-12);
  // A model that is not a chain of hitches runs on one thread, said so.
  const Result sleigh = run({"run", "sleigh", "--threads", "2"});
  EXPECT_EQ(sleigh.code, 0) << sleigh.err;
  EXPECT_EQ(parse_summary(sleigh.out)["threads"], "1");
  EXPECT_THAT(sleigh.err, HasSubstr("--threads 2: ran on one thread"));
}

TEST(CommandLine, BadInputGetsAClearErrorAndNonZeroExit) {
  expect_failure({"run", "sled"}, "unknown scene 'sled' (known: particle, sleigh, sleigh_contact, snakeboard, sleigh_chain, wheeled_train, suslov, veselova, chaplygin_ball, ball_chain, rolling_disk)");
  expect_failure({"run", "sleigh", "--set", "mass=2"},
                 "unknown parameter 'mass' for scene 'sleigh' (parameters: m, I, a, v0, omega0, x0, y0, theta0)");
  expect_failure({"run", "sleigh", "--set", "m=heavy"}, "--set m=heavy: 'heavy' is not a number");
  expect_failure({"run", "sleigh", "--set", "m"}, "--set 'm': expected NAME=VALUE");
  expect_failure({"run", "sleigh", "--set", "m=0"}, "sleigh: parameter m = 0 must be positive");
  expect_failure({"run", "sleigh", "--set", "I=inf"}, "'inf' is not finite");
  expect_failure({"run", "sleigh", "--dt", "-0.1"}, "--dt");
  expect_failure({"run", "sleigh", "--dt", "0"}, "the step must be positive");
  expect_failure({"run", "sleigh", "--dt", "fast"}, "--dt");
  expect_failure({"run", "sleigh", "--t-end", "-1"}, "--t-end");
  expect_failure({"run", "sleigh", "--every", "0"}, "--every 0: must be at least 1");
  expect_failure({"run", "sleigh", "--backend", "lapack"}, "unknown backend 'lapack' (valid: auto, block-diagonal, dense, banded, cholmod-natural, cholmod-amd)");
  expect_failure({"run", "sleigh", "--out", "/nonexistent-dir/x.csv"}, "cannot open '/nonexistent-dir/x.csv' for writing");
  expect_failure({"run", "sleigh", "--frobnicate"}, "frobnicate");
  expect_failure({"run"}, "scene");
  expect_failure({}, "subcommand");
  expect_failure({"fly"}, "unknown command 'fly' (commands: run, batch, list, wp, animate, view)");
  expect_failure({"run", "sleigh_chain", "--hitch", "rigid"}, "unknown hitch mode 'rigid' (valid: oneform, holonomic)");
  expect_failure({"run", "sleigh", "--method", "euler"},
                 "unknown method 'euler' (valid: reflection, dla-midpoint, dla-left, rk4, arkode-dp5, arkode-verner, arkode-fehlberg8)");
  expect_failure({"run", "sleigh", "--project"}, "--project applies to the methods rk4, arkode-dp5, arkode-verner and arkode-fehlberg8");
  expect_failure({"run", "sleigh", "--out", "x.txt"},
                 "--out x.txt: name the file .csv (text) or .h5 / .hdf5 (HDF5), or give - for CSV on standard output");
  expect_failure({"batch", "sleigh", "--count", "2", "--out", "x.dat"}, "--out x.dat: name the file .csv (text) or .h5 / .hdf5 (HDF5)");
  expect_failure({"run", "sleigh", "--out", "-", "--checkpoint", "x.h5"}, "--checkpoint with --out -: a resumed run cannot continue standard output");
  expect_failure({"run", "sleigh", "--method", "rk4", "--tol", "1e-6"},
                 "--tol applies to the reflection method (adaptive steps) and to arkode-dp5, arkode-verner and arkode-fehlberg8");
  expect_failure({"run", "sleigh", "--order", "6", "--tol", "1e-6", "--error-estimate"},
                 "--error-estimate applies to fixed steps: adaptive steps (--tol) control their error");
  expect_failure({"run", "sleigh", "--order", "6", "--tol", "0"}, "tolerance = 0 must lie in [1e-15, 1)");
  expect_failure({"run", "sleigh", "--method", "rk4", "--hitch", "oneform"}, "--hitch applies to the reflection method only");
  expect_failure({"run", "sleigh", "--method", "arkode-dp5", "--tol", "0"}, "tolerance = 0 must lie in [1e-15, 1)");
  expect_failure({"run", "sleigh_chain", "--restart", "-1"},
                 "--restart '-1': expected auto, 0 (never) or a number of steps K from 1 to 1e9");
  expect_failure({"run", "sleigh_chain", "--restart", "often"}, "--restart 'often': expected auto, 0 (never)");
  expect_failure({"run", "sleigh_chain", "--restart-tol", "0"}, "--restart-tol 0.000000: must be positive");
  expect_failure({"run", "sleigh_chain", "--restart", "10", "--restart-tol", "1e-6"},
                 "--restart-tol applies to --restart auto");
  expect_failure({"run", "sleigh_chain", "--monitor-every", "-3"}, "--monitor-every -3: must be 0 (never) or positive");
  expect_failure({"run", "sleigh_chain", "--monitor-every", "0"},
                 "--monitor-every 0 turns off the measurement that --restart auto needs");
  expect_failure({"run", "sleigh", "--method", "rk4", "--restart", "auto"}, "--restart applies to the reflection method only");
  expect_failure({"run", "sleigh_chain", "--set", "bodies=0"}, "parameter bodies = 0 must be a whole number");
  expect_failure({"run", "sleigh_chain", "--threads", "-1"},
                 "--threads -1: give the threads for one step of the chain, or 0 to let the run choose");
  expect_failure({"run", "sleigh_chain", "--set", "bodies=40", "--hitch", "oneform", "--threads", "21"},
                 "--threads 21 for 40 bodies: each thread needs at least 2 bodies, so at most 20");
  expect_failure({"run", "sleigh_chain", "--backend", "block-diagonal"},
                 "backend block-diagonal: C has a coupled block of 28 one-forms");
  // Dependent one-forms at the start: wheels on one line (r = 0, phi0 = 0).
  expect_failure({"run", "snakeboard", "--set", "r=0", "--set", "phi0=0"}, "dependent");
}

TEST(CommandLine, RestartsAreReportedAndChosen) {
  // The default: automatic restarts, none needed on the sleigh before t = 100.
  Result r = run({"run", "sleigh", "--t-end", "100"});
  ASSERT_EQ(r.code, 0) << r.err;
  auto kv = parse_summary(r.out);
  EXPECT_EQ(kv.at("restart"), "auto");
  EXPECT_LE(std::stod(kv.at("parasitic_max")), 2e-6) << "the tolerance dt^3, or just above it where it restarted";
  EXPECT_EQ(r.err, "") << "no warning";
  // The paper's plain method: by t = 100 the mode holds much of the energy, and the run says so.
  // Its trajectory is 77 off at t = 100 (against ARKODE at 1e-12): the accuracy check says so.
  r = run({"run", "sleigh", "--t-end", "100", "--restart", "0"});
  ASSERT_EQ(r.code, 3) << r.err;
  EXPECT_THAT(r.err, HasSubstr("nonholo run: the estimated error in q"));
  kv = parse_summary(r.out);
  EXPECT_EQ(kv.at("restart"), "0");
  EXPECT_EQ(kv.at("restarts"), "0");
  EXPECT_GT(std::stod(kv.at("parasitic_max")), 0.1);
  EXPECT_GT(std::stod(kv.at("energy_rel_err_max")), 0.1);
  EXPECT_LE(std::stod(kv.at("energy_post_rel_err_max")), 1e4 * 2.3e-16) << "exact: the mode is not an energy error";
  EXPECT_THAT(r.err, HasSubstr("nonholo run: warning: the period-2 mode reached"));
  EXPECT_THAT(r.err, HasSubstr("Use --restart auto"));
  // Every K steps; no measurement at all.
  kv = parse_summary(run({"run", "sleigh", "--t-end", "1", "--restart", "25"}).out);
  EXPECT_EQ(kv.at("restart"), "25");
  EXPECT_EQ(kv.at("restarts"), "4");
  kv = parse_summary(run({"run", "sleigh", "--t-end", "1", "--restart", "0", "--monitor-every", "0"}).out);
  EXPECT_EQ(kv.at("parasitic_max"), "nan") << "never measured";
  // A tolerance so small that every measurement restarts.
  kv = parse_summary(run({"run", "sleigh", "--t-end", "1", "--restart-tol", "1e-300", "--monitor-every", "1"}).out);
  EXPECT_EQ(kv.at("restarts"), "100");
  EXPECT_LE(std::stod(kv.at("energy_post_rel_err_max")), 1e-14) << "energy-exact restarts";
  // Other methods have no multipliers to restart.
  EXPECT_EQ(parse_summary(run({"run", "sleigh", "--method", "rk4"}).out).count("restarts"), 0u);
}

TEST(CommandLine, DrivenRunsReportTheWorkAndTheEnergyBalance) {
  // The main job's scene, shorter: the energy is not an invariant; the work of the lead's
  // force and the balance error of the discrete work-energy identity are reported instead.
  Result r = run({"run", "wheeled_train", "--set", "bodies=50", "--t-end", "5"});
  ASSERT_EQ(r.code, 0) << r.err;
  auto kv = parse_summary(r.out);
  EXPECT_GT(std::stod(kv.at("work")), 10.0);
  EXPECT_EQ(kv.count("energy_post_rel_err_max"), 0u);
  EXPECT_LE(std::stod(kv.at("energy_balance_err_max")), 1e-5) << "holonomic hitches: their corrections";
  EXPECT_LE(std::stod(kv.at("energy_rel_err_max")), 1e-3) << "net of the work to t_k: O(h^2)";
  // One-form hitches: the identity holds to round-off, restarts included.
  r = run({"run", "wheeled_train", "--set", "bodies=50", "--t-end", "5", "--hitch", "oneform"});
  ASSERT_EQ(r.code, 0) << r.err;
  kv = parse_summary(r.out);
  EXPECT_LE(std::stod(kv.at("energy_balance_err_max")), 1e-13);
  EXPECT_GT(std::stol(kv.at("restarts")), 0);
  // Methods without a discrete work identity balance their energy against the work integrated
  // from the power at the step ends (Gregory's rule, order 6): rk4's error (order 4) is small.
  kv = parse_summary(run({"run", "wheeled_train", "--set", "bodies=5", "--t-end", "1", "--method", "rk4"}).out);
  EXPECT_NEAR(std::stod(kv.at("work")), 0.3146, 1e-4);
  EXPECT_LE(std::stod(kv.at("energy_balance_err_max")), 1e-10) << "measured 9e-12";
  EXPECT_EQ(kv.at("energy_rel_err_max"), kv.at("energy_balance_err_max"));
}

TEST(CommandLine, FailureMessagesSayWhatWouldFixThem) {
  // The period-2 mode grows (plain method, driven train) until the energy balance is off by
  // half (later, at t = 31, the position iteration fails): restarts help, a smaller step does not.
  Result r = run({"run", "wheeled_train", "--set", "bodies=30", "--restart", "0", "--t-end", "100"});
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_THAT(r.err, HasSubstr("the energy balance error"));
  EXPECT_THAT(r.err, HasSubstr("the period-2 mode reached "));
  EXPECT_THAT(r.err, HasSubstr("Use --restart auto"));
  EXPECT_THAT(r.err, ::testing::Not(HasSubstr("reduce --dt")));
  EXPECT_THAT(r.err, ::testing::Not(HasSubstr("warning"))) << "the failure says it all";
  EXPECT_EQ(parse_summary(r.out).at("status"), "blew-up");
  // The same train with the defaults runs.
  r = run({"run", "wheeled_train", "--set", "bodies=30", "--t-end", "100"});
  EXPECT_EQ(r.code, 0) << r.err;
  // A step too large for the position iteration: a smaller step helps.
  r = run({"run", "sleigh_chain", "--set", "omega0=20", "--dt", "0.1"});
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_THAT(r.err, HasSubstr("the step is too large for the position iteration: reduce the step size (h = 0.1)"));
  // At that step it runs, but 2.4 off at t = 10 (ARKODE at 1e-12): the accuracy check says so and
  // names a step (0.00258); at that step the run is ok.
  r = run({"run", "sleigh_chain", "--set", "omega0=20", "--dt", "0.01"});
  EXPECT_EQ(r.code, 3) << r.out;
  EXPECT_EQ(parse_summary(r.out).at("status"), "inaccurate");
  const auto at = r.err.find("use --dt ");
  ASSERT_NE(at, std::string::npos) << r.err;
  const std::string dt = r.err.substr(at + 9, r.err.find(' ', at + 9) - at - 9);
  EXPECT_LT(std::stod(dt), 0.005);
  EXPECT_EQ(run({"run", "sleigh_chain", "--set", "omega0=20", "--dt", dt}).code, 0) << dt;
}

// --order 4, 6 and 8: the summary names the order and the composition, counts factorisations
// (one per plain step, plus the start), drops the post-momentum energy (not defined for a
// composed step) and, with forces, balances the energy against the work by Gregory's rule (no
// discrete identity); the energy of p~ is exact without forces. Wrong combinations are refused
// with the option's name.
TEST(CommandLine, HigherOrdersAreReportedAndChecked) {
  Result r = run({"run", "sleigh", "--order", "6", "--dt", "0.1", "--t-end", "10"});
  ASSERT_EQ(r.code, 0) << r.err;
  auto kv = parse_summary(r.out);
  EXPECT_EQ(kv.at("order"), "6");
  EXPECT_EQ(kv.at("composition"), "blanes-moan6");
  EXPECT_EQ(kv.at("factorizations"), std::to_string(100 * 20 + 1));
  EXPECT_EQ(kv.at("restarts"), "100");
  EXPECT_EQ(kv.at("energy_post_rel_err_max"), "nan");
  EXPECT_LE(std::stod(kv.at("energy_rel_err_max")), 1e-14);
  kv = parse_summary(run({"run", "sleigh", "--order", "4", "--composition", "triple-jump", "--t-end", "1"}).out);
  EXPECT_EQ(kv.at("composition"), "triple-jump");
  EXPECT_EQ(kv.at("factorizations"), std::to_string(100 * 6 + 1));
  kv = parse_summary(run({"run", "sleigh", "--order", "8", "--t-end", "1"}).out);
  EXPECT_EQ(kv.at("composition"), "kahan-li17");
  EXPECT_EQ(kv.at("factorizations"), std::to_string(100 * 34 + 1));
  kv = parse_summary(run({"run", "sleigh", "--t-end", "1"}).out);
  EXPECT_EQ(kv.at("order"), "2");
  EXPECT_EQ(kv.count("composition"), 0u);
  EXPECT_EQ(kv.at("factorizations"), "101");
  kv = parse_summary(run({"run", "sleigh", "--method", "rk4", "--t-end", "1"}).out);
  EXPECT_EQ(kv.count("order"), 0u);
  EXPECT_EQ(kv.at("factorizations"), "400") << "one per evaluation of the equations";
  r = run({"run", "wheeled_train", "--set", "bodies=4", "--order", "4", "--t-end", "1", "--hitch", "oneform"});
  ASSERT_EQ(r.code, 0) << r.err;
  kv = parse_summary(r.out);
  EXPECT_LE(std::stod(kv.at("energy_balance_err_max")), 1e-7) << "measured 4.6e-9";
  EXPECT_EQ(kv.at("energy_rel_err_max"), kv.at("energy_balance_err_max"));
  EXPECT_LE(std::stod(kv.at("residual_max")), 1e-14);
  // A batch with composed steps, and an estimate per trajectory.
  const std::string path = temp_path("batch_order.csv");
  r = run({"batch", "sleigh", "--count", "3", "--order", "4", "--t-end", "1", "--error-estimate",
           "--vary", "a=0.1:0.3", "--out", path});
  ASSERT_EQ(r.code, 0) << r.err;
  kv = parse_summary(r.out);
  EXPECT_EQ(kv.at("order"), "4");
  EXPECT_EQ(kv.at("factorizations"), std::to_string(3 * (100 * 12 + 1)));
  EXPECT_LT(std::stod(kv.at("error_estimate")), 1e-9);
  std::ifstream in(path);
  std::string header;
  std::getline(in, header);
  EXPECT_THAT(header, HasSubstr(",error_estimate,status"));
  std::remove(path.c_str());

  expect_failure({"run", "sleigh", "--order", "3"}, "--order/--composition: order = 3 must be 2, 4, 6 or 8");
  expect_failure({"run", "sleigh", "--order", "4", "--composition", "yoshida7"}, "yoshida7 is not of order 4");
  expect_failure({"run", "sleigh", "--composition", "rk"}, "unknown composition 'rk'");
  expect_failure({"run", "sleigh", "--method", "rk4", "--order", "4"}, "--order applies to the reflection method only");
  expect_failure({"run", "sleigh_contact", "--order", "4"}, "needs a constant metric");
}

// --error-estimate against the true error: the run's CSV compared with the exact sleigh at
// every output time, for every method. A fixed-step estimate (Richardson-scaled) must be
// within 10% of the truth; ARKODE's (from tol/100) within a factor 3.
TEST(CommandLine, ErrorEstimateIsCloseToTheTrueError) {
  const scenarios::SleighExact exact(1.0, 1.0, 0.2, 1.0, 1.0, 0.0, 0.0, 0.0);
  const std::string path = temp_path("estimate.csv");
  const std::vector<std::vector<std::string>> cases{
      {"--order", "2", "--dt", "0.1"},         {"--order", "4", "--dt", "0.1"},
      {"--order", "6", "--dt", "0.2"},         {"--method", "rk4", "--dt", "0.1"},
      {"--method", "dla-midpoint", "--dt", "0.1"}, {"--method", "arkode-verner", "--dt", "1", "--tol", "1e-8"}};
  for (const auto& c : cases) {
    std::vector<std::string> args{"run", "sleigh", "--t-end", "10", "--error-estimate", "--out", path};
    args.insert(args.end(), c.begin(), c.end());
    const Result r = run(args);
    ASSERT_EQ(r.code, 0) << r.err;
    const double estimate = std::stod(parse_summary(r.out).at("error_estimate"));
    std::ifstream in(path);
    std::string line;
    std::getline(in, line);
    double truth = 0.0;
    while (std::getline(in, line)) {
      std::istringstream row(line);
      double t, x, y, theta;
      char comma;
      row >> t >> comma >> x >> comma >> y >> comma >> theta;
      truth = std::max(truth, (Eigen::Vector3d(x, y, theta) - exact.configuration(t)).lpNorm<Eigen::Infinity>());
    }
    std::cout << "[estimate] " << c[1] << " " << c[3] << ": estimate " << estimate << ", true error " << truth
              << ", ratio " << estimate / truth << "\n";
    const bool adaptive = c[1] == "arkode-verner";
    EXPECT_GE(estimate / truth, adaptive ? 0.33 : 0.9) << r.out;
    EXPECT_LE(estimate / truth, adaptive ? 3.0 : 1.1) << r.out;
  }
  std::remove(path.c_str());
  // Without the companion, the in-run accuracy check's estimate (tests/test_accuracy.cpp).
  EXPECT_EQ(parse_summary(run({"run", "sleigh", "--t-end", "1"}).out).count("error_estimate"), 1u);
}

TEST(CommandLine, FailedStepStopsTheRunKeepsTheCsvAndExitsWithTwo) {
  // The axles reach phi = pi/2 after one step: both wheel rows then lie on one line.
  const std::string path = temp_path("jam.csv");
  const Result r = run({"run", "snakeboard", "--dt", "0.01", "--set", "phi0=1.5607963267948966",
                        "--set", "phi_dot0=1", "--set", "v0=0", "--out", path});
  EXPECT_EQ(r.code, 2) << r.out << r.err;
  // phi lands on pi/2 to the last bit: the pivot is 0 or a few ulps (dependent or nearly).
  EXPECT_THAT(r.err, HasSubstr("step 1 from t = 0 failed: "));
  EXPECT_THAT(r.err, HasSubstr("dependent-one-forms: pivot of row 1 of C"));
  EXPECT_THAT(r.out, HasSubstr("dependent-one-forms"));
  std::ifstream in(path);
  std::string header, row0, more;
  std::getline(in, header);
  std::getline(in, row0);
  EXPECT_THAT(row0, StartsWith("0,"));
  EXPECT_FALSE(std::getline(in, more)) << "only the initial row";
  std::remove(path.c_str());
}

// `nonholo wp --quick` writes every CSV with its header and one row per method point.
TEST(CommandLine, WorkPrecisionWritesItsTables) {
  const std::string dir = temp_path("wp");
  const Result r = run({"wp", "--quick", "--out", dir});
  ASSERT_EQ(r.code, 0) << r.err;
  for (const char* name : {"work_precision.csv", "long_time.csv", "equal_cost.csv", "error_estimate.csv",
                           "paper_particle_energy.csv", "paper_sleigh_error.csv", "paper_snakeboard_path.csv"}) {
    std::ifstream in(dir + "/" + name);
    ASSERT_TRUE(in) << name;
    std::string header, row;
    std::getline(in, header);
    EXPECT_TRUE(std::getline(in, row)) << name << " has no rows";
  }
  std::ifstream in(dir + "/work_precision.csv");
  std::string line;
  std::getline(in, line);
  EXPECT_EQ(line,
            "scene,method,project,h,tol,cpu_s,rhs_evals,factorizations,steps,error,energy_err,energy_post_err,residual,"
            "status");
  int rows = 0, ok = 0;
  while (std::getline(in, line)) {
    ++rows;
    ok += line.size() > 3 && line.compare(line.size() - 3, 3, ",ok") == 0;
  }
  // quick: 2 scenes x (4 methods x 2 steps + rk4+project x 2 + orders 4, 6 and 8 x 2 composed
  // steps + adaptive orders 2, 4, 6, 8 x 1 tolerance + 4 ARKODE series x 1 tolerance).
  EXPECT_EQ(rows, 2 * (8 + 2 + 6 + 4 + 4));
  EXPECT_EQ(ok, rows);
  std::filesystem::remove_all(dir);
  expect_failure({"wp", "--out", "/proc/nonholo-cannot-write-here"}, "nonholo wp: cannot create");
}

TEST(CommandLine, HelpExitsWithZero) {
  const Result r = run({"run", "--help"});
  EXPECT_EQ(r.code, 0);
  EXPECT_THAT(r.out, HasSubstr("--set"));
}

}  // namespace
}  // namespace nonholo

// Issue 11: sizes the machine cannot hold are refused with the reason, before any work.
namespace nonholo {
namespace {

TEST(CommandLine, RefusesSizesTheMachineCannotHold) {
  const Result count = run({"batch", "sleigh", "--count", "1000000000000"});
  EXPECT_EQ(count.code, 1);
  EXPECT_THAT(count.err, HasSubstr("--count 1000000000000: the results table would need "));
  EXPECT_THAT(count.err, HasSubstr(" bytes per trajectory); this machine has "));
  const Result threads = run({"batch", "sleigh", "--count", "2", "--t-end", "0.01", "--threads", "5000"});
  EXPECT_EQ(threads.code, 1);
  EXPECT_THAT(threads.err, HasSubstr("--threads 5000: at most "));
  const Result t_end = run({"run", "sleigh", "--t-end", "1e300"});
  EXPECT_EQ(t_end.code, 1);
  EXPECT_THAT(t_end.err, HasSubstr("t_end 1e+300 / dt 0.01 = 1e+302 steps, more than the 1e+12 a run may take"));
  const Result dt = run({"run", "sleigh", "--dt", "1e-300"});
  EXPECT_EQ(dt.code, 1);
  EXPECT_THAT(dt.err, HasSubstr("t_end 10 / dt 1e-300 = 1e+301 steps"));
}

}  // namespace
}  // namespace nonholo

namespace nonholo {
namespace {

// The stiff train at dt 0.15 ends ok with three warnings, one of each kind (stability, accuracy,
// method): one line of them by default, none with --quiet, one line each with its kind with
// --verbose; the summary line lists the kinds in every case.
TEST(CommandLine, QuietAndVerboseSayLessAndMore) {
  const std::vector<std::string> args{"run", "wheeled_train", "--set", "bodies=5", "--set", "k=50",
                                      "--dt", "0.15", "--t-end", "6"};
  auto with = [&args](const std::string& flag) {
    std::vector<std::string> a = args;
    if (!flag.empty()) a.push_back(flag);
    return run(a);
  };
  const Result normal = with(""), quiet = with("--quiet"), verbose = with("--verbose");
  for (const Result* r : {&normal, &quiet, &verbose}) {
    EXPECT_EQ(r->code, 0) << r->err;
    EXPECT_EQ(parse_summary(r->out).at("warnings"), "stability,accuracy,method") << r->out;
  }
  EXPECT_EQ(quiet.err, "");
  EXPECT_THAT(normal.err, StartsWith("nonholo run: warning: dt = 0.15 is 0.638"));
  EXPECT_EQ(std::count(normal.err.begin(), normal.err.end(), '\n'), 1) << normal.err;
  EXPECT_THAT(verbose.err, HasSubstr("nonholo run: warning (stability): dt = 0.15"));
  EXPECT_THAT(verbose.err, HasSubstr("\nnonholo run: warning (accuracy): the accuracy check's step of 2 dt failed"));
  EXPECT_THAT(verbose.err, HasSubstr("\nnonholo run: warning (method): the period-2 mode reached"));
  EXPECT_THAT(run({"run", "sleigh", "--quiet", "--verbose"}).err, HasSubstr("--quiet and --verbose: give one of them"));
}

}  // namespace
}  // namespace nonholo
