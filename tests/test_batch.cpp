// Batched trajectories (nonholo/batch.hpp and `nonholo batch`): the same bits whatever the
// number of threads, equal to a serial run; one bad trajectory neither stops nor corrupts the
// others; bad arguments are refused; nothing but the summary reaches a non-terminal stderr.
#include <nonholo/batch.hpp>
#include <nonholo/scenarios/batch.hpp>
#include <nonholo/scenarios/command_line.hpp>
#include <nonholo/scenarios/scene.hpp>
#include <nonholo/start.hpp>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <memory>
#include <sstream>
#include <unistd.h>
#include <sys/wait.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <thread>

#include "output/batch_table.hpp"
#include "run/progress.hpp"
#include "support/bitwise_equal.hpp"
#include "support/expect_error.hpp"
#include "support/run_cli.hpp"
#include "support/random_model.hpp"

namespace nonholo {
namespace {

using testing::bitwise_equal;

BatchOptions on(int threads) {
  BatchOptions b;
  b.threads = threads;
  return b;
}

std::vector<State> sleigh_starts(const Model& model, int count) {
  Workspace ws(model);
  std::vector<State> starts;
  for (int i = 0; i < count; ++i) {
    const Vector q = testing::random_vector(static_cast<std::uint32_t>(i + 1), 3, 0.5);
    const Vector v = testing::random_vector(static_cast<std::uint32_t>(i + 1000), 3);
    starts.push_back(start_from_velocity(model, ws, 0.0, q, v));
  }
  return starts;
}

TEST(Batch, ResultsDoNotDependOnTheThreadCount) {
  const auto& info = scenarios::find_scene("sleigh_chain");
  auto p = info.defaults();
  p.set("bodies", 4);
  const auto setup = info.build(p);
  Workspace ws(setup.model);
  std::vector<State> serial;
  for (int i = 0; i < 40; ++i) {
    Vector v0 = setup.v0;
    v0[2] = 0.1 * i - 2.0;  // body 0 turn rates from -2 to 1.9
    serial.push_back(start_from_velocity(setup.model, ws, 0.0, setup.q0, v0));
  }
  std::vector<State> one = serial, two = serial, three = serial;
  RattleOptions o{0.01};
  o.restart.tolerance = 1e-8;  // automatic restarts (and their measurement schedule) in play
  long restarts = 0;
  for (State& s : serial) {
    for (int k = 0; k < 300; ++k) ASSERT_EQ(step(setup.model, ws, s, o), Status::Ok);
    restarts += s.restarts;
  }
  integrate_batch(setup.model, one, 300, o, on(1));
  const auto outcome2 = integrate_batch(setup.model, two, 300, o, on(2));
  const auto outcome3 = integrate_batch(setup.model, three, 300, o, on(3));
  EXPECT_GT(restarts, 40);
  for (std::size_t i = 0; i < serial.size(); ++i) {
    EXPECT_TRUE(bitwise_equal(one[i].q, serial[i].q)) << i;
    EXPECT_TRUE(bitwise_equal(two[i].q, serial[i].q)) << i;
    EXPECT_TRUE(bitwise_equal(three[i].p, serial[i].p)) << i;
    EXPECT_TRUE(bitwise_equal(two[i].lambda, serial[i].lambda)) << i;
    EXPECT_EQ(outcome2[i].restarts, serial[i].restarts) << i;
    EXPECT_EQ(outcome3[i].parasitic_max, outcome2[i].parasitic_max) << i;
  }
}

// Every thread's workspace is written at every step: two of them in one cache line halved the
// 2-thread speed-up of a sleigh batch (measured 1.2 against 1.9). Heap-allocated workspaces,
// as integrate_batch makes them, start and end on cache-line boundaries.
TEST(Batch, WorkspacesDoNotShareCacheLines) {
  const auto& info = scenarios::find_scene("sleigh");
  const auto setup = info.build(info.defaults());
  static_assert(alignof(Workspace) >= 64 && sizeof(Workspace) % 64 == 0);
  for (int i = 0; i < 8; ++i) {
    const auto ws = std::make_unique<Workspace>(setup.model);
    EXPECT_EQ(reinterpret_cast<std::uintptr_t>(ws.get()) % 64, 0u);
  }
}

TEST(Batch, OneBadTrajectoryDoesNotStopOrCorruptTheOthers) {
  const auto& info = scenarios::find_scene("sleigh");
  const auto setup = info.build(info.defaults());
  std::vector<State> good = sleigh_starts(setup.model, 16);
  std::vector<State> mixed = good;
  mixed[5].p[0] = std::numeric_limits<double>::quiet_NaN();  // this one cannot step
  const State bad_before = mixed[5];
  const RattleOptions o{0.01};
  const auto reference = integrate_batch(setup.model, good, 500, o, on(2));
  const auto outcome = integrate_batch(setup.model, mixed, 500, o, on(2));
  for (std::size_t i = 0; i < good.size(); ++i) {
    if (i == 5) continue;
    EXPECT_EQ(outcome[i].status, Status::Ok) << i;
    EXPECT_EQ(outcome[i].steps, 500) << i;
    EXPECT_TRUE(bitwise_equal(mixed[i].q, good[i].q)) << i;
  }
  EXPECT_EQ(outcome[5].status, Status::NonFiniteState);
  EXPECT_EQ(outcome[5].steps, 0);
  EXPECT_THAT(outcome[5].message, ::testing::HasSubstr("NaN"));
  EXPECT_TRUE(bitwise_equal(mixed[5].q, bad_before.q)) << "left as it was";
  // An exception inside a job is caught and reported for that index only.
  const auto errors = parallel_for(8, 2, [](long i, int) {
    if (i == 3) throw std::runtime_error("job 3 broke");
  });
  for (long i = 0; i < 8; ++i) EXPECT_EQ(errors[static_cast<std::size_t>(i)], i == 3 ? "job 3 broke" : "");
}

using Cli = testing::CliResult;

Cli cli(std::vector<std::string> args) { return testing::run_cli(std::move(args)); }

std::string slurp(const std::string& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

std::string temp(const std::string& name) {
  return (std::filesystem::temp_directory_path() / ("nonholo_batch_" + std::to_string(::getpid()) + "_" + name)).string();
}

TEST(BatchCommand, FileIsByteIdenticalForAnyThreadCount) {
  std::string first;
  for (const char* threads : {"1", "2", "3"}) {
    const std::string path = temp(std::string("t") + threads + ".csv");
    const Cli r = cli({"batch", "sleigh_chain", "--count", "12", "--threads", threads, "--set", "bodies=5",
                       "--vary", "omega0=-1:1", "--vary", "k=0:2", "--t-end", "2", "--out", path});
    ASSERT_EQ(r.code, 0) << r.err;
    EXPECT_THAT(r.out, ::testing::HasSubstr(std::string("trajectories=12 threads=") + threads));
    const std::string text = slurp(path);
    EXPECT_EQ(std::count(text.begin(), text.end(), '\n'), 13) << "a header and 12 rows";
    if (first.empty()) first = text;
    EXPECT_EQ(text, first) << threads << " threads";
    std::remove(path.c_str());
  }
  EXPECT_THAT(first, ::testing::StartsWith(
                         "trajectory,omega0,k,t_final,x0,y0,theta0,energy_rel_err_max,energy_post_rel_err_max,"
                         "residual_max,gap_max,restarts,parasitic_max,status\n0,"));
}

TEST(BatchCommand, FailedTrajectoriesAreReportedAndTheOthersMatchSingleRuns) {
  const std::string path = temp("mixed.csv");
  // Masses drawn in [-0.5, 1.5]: some are refused at set-up, the others run.
  const Cli r = cli({"batch", "sleigh", "--count", "10", "--threads", "2", "--vary", "m=-0.5:1.5", "--t-end", "1",
                     "--seed", "7", "--out", path});
  EXPECT_EQ(r.code, 2) << r.out << r.err;
  EXPECT_THAT(r.err, ::testing::HasSubstr("trajectories failed; first: trajectory"));
  std::ifstream in(path);
  std::string line;
  std::getline(in, line);
  int failed = 0, ok = 0;
  while (std::getline(in, line)) {
    std::vector<std::string> cells;
    std::stringstream ls(line);
    for (std::string c; std::getline(ls, c, ',');) cells.push_back(c);
    ASSERT_EQ(cells.size(), 13u) << line;
    const double m = std::stod(cells[1]);
    if (m > 0) {
      ++ok;
      EXPECT_EQ(cells.back(), "ok");
      // The same parameters through `nonholo run`: the same final x to the last digit.
      const std::string single = temp("single.csv");
      ASSERT_EQ(cli({"run", "sleigh", "--set", "m=" + cells[1], "--t-end", "1", "--out", single}).code, 0);
      std::ifstream s(single);
      std::string row, last;
      while (std::getline(s, row)) last = row;
      EXPECT_EQ(last.substr(last.find(',') + 1, cells[3].size()), cells[3]) << "x of trajectory " << cells[0];
      std::remove(single.c_str());
    } else {
      ++failed;
      EXPECT_EQ(cells.back(), "invalid-input") << line;
    }
  }
  EXPECT_GT(ok, 0);
  EXPECT_GT(failed, 0);
  std::remove(path.c_str());
}

TEST(BatchCommand, BadArgumentsAreRefused) {
  auto fails = [](std::vector<std::string> args, const std::string& fragment) {
    const Cli r = cli(args);
    EXPECT_EQ(r.code, 1) << ::testing::PrintToString(args);
    EXPECT_THAT(r.err + r.out, ::testing::HasSubstr(fragment)) << ::testing::PrintToString(args);
  };
  fails({"batch", "sleigh"}, "--count is required");
  fails({"batch", "sleigh", "--count", "0"}, "--count 0: must be at least 1");
  fails({"batch", "sleigh", "--count", "3", "--threads", "0"}, "--threads 0: must be at least 1");
  fails({"batch", "sleigh", "--count", "3", "--vary", "m=1"}, "--vary 'm=1': expected NAME=LO:HI");
  fails({"batch", "sleigh", "--count", "3", "--vary", "mass=1:2"}, "unknown parameter 'mass' for scene 'sleigh'");
  fails({"batch", "sleigh", "--count", "3", "--vary", "m=2:1"}, "LO must not exceed HI");
  fails({"batch", "sleigh", "--count", "3", "--vary", "m=x:1"}, "'x' is not a number");
  fails({"batch", "sled", "--count", "3"}, "unknown scene 'sled'");
}

TEST(ListCommand, NamesEveryScenesParametersAndDefaults) {
  const Cli r = cli({"list"});
  ASSERT_EQ(r.code, 0);
  for (const auto& info : scenarios::scene_catalogue()) {
    EXPECT_THAT(r.out, ::testing::HasSubstr(info.name + ": " + info.description));
    for (const auto& p : info.parameters) EXPECT_THAT(r.out, ::testing::HasSubstr("  " + p.name + " = "));
  }
  EXPECT_THAT(r.out, ::testing::HasSubstr("  bodies = 1000  number of bodies N"));
}

// The progress bar is for terminals only: with stderr redirected to a file, a successful
// run and batch write nothing there.
TEST(Progress, NothingExtraWhenStderrIsNotATerminal) {
  const std::string err = temp("stderr.txt");
  const std::string cmd = std::string(NONHOLO_CLI) + " run sleigh_chain --set bodies=300 --t-end 3 > /dev/null 2> " + err +
                          " && " + NONHOLO_CLI + " batch sleigh --count 200 > /dev/null 2>> " + err;
  ASSERT_EQ(std::system(cmd.c_str()), 0);
  EXPECT_EQ(slurp(err), "");
  std::remove(err.c_str());
}

// On a terminal (a pseudo-terminal from script(1)) a long run draws the bar on stderr. The
// run must outlast the bar's first 0.5 s: 1000 steps of 20000 bodies, about 2 s.
TEST(Progress, DrawnOnATerminal) {
  if (std::system("command -v script > /dev/null 2>&1") != 0) GTEST_SKIP() << "script(1) is not installed";
  const std::string log = temp("tty.txt");
  const std::string cmd = "script -qec '" + std::string(NONHOLO_CLI) +
                          " run sleigh_chain --set bodies=20000 --t-end 10 > /dev/null' /dev/null > " + log;
  ASSERT_EQ(std::system(cmd.c_str()), 0);
  const std::string text = slurp(log);
  EXPECT_THAT(text, ::testing::HasSubstr("sleigh_chain [#"));
  EXPECT_THAT(text, ::testing::HasSubstr("%"));
  EXPECT_THAT(text, ::testing::HasSubstr("ETA "));
  std::remove(log.c_str());
}

// A long set-up (a million bodies takes seconds) shows its phases on the progress line, which
// is wiped before the steps (NONHOLO_PROGRESS=1 draws it without a terminal): nothing is left
// behind, not even a newline.
TEST(Progress, SetUpPhasesAreShownThenWiped) {
  const std::string err = temp("setup_status.txt");
  for (const std::string& command : {std::string(" run sleigh_chain --set bodies=300 --t-end 0.05"),
                                     std::string(" batch sleigh_chain --set bodies=300 --t-end 0.05 --count 2")}) {
    const std::string cmd = "NONHOLO_PROGRESS=1 " + std::string(NONHOLO_CLI) + command + " > /dev/null 2> " + err;
    ASSERT_EQ(std::system(cmd.c_str()), 0) << command;
    const std::string text = slurp(err);
    EXPECT_THAT(text, ::testing::HasSubstr("\rsetting up sleigh_chain (300 bodies): building model...")) << command;
    EXPECT_THAT(text, ::testing::HasSubstr("\rsetting up sleigh_chain (300 bodies): analysing C...")) << command;
    EXPECT_THAT(text, ::testing::HasSubstr("\rsetting up sleigh_chain (300 bodies): starting...")) << command;
    EXPECT_EQ(text.find('\n'), std::string::npos) << command;
    ASSERT_FALSE(text.empty());
    EXPECT_EQ(text.back(), '\r') << command;  // the line wiped, the cursor back at its start
  }
  std::remove(err.c_str());
}

TEST(Progress, EtaIsFormattedAtFixedWidth) {
  using scenarios::Progress;
  EXPECT_EQ(Progress::format_eta(65.2), "ETA      1m05s");
  EXPECT_EQ(Progress::format_eta(7384.0), "ETA   2h03m04s");
  EXPECT_EQ(Progress::format_eta(-1.0), "ETA    --    ");
  EXPECT_EQ(Progress::format_eta(NAN), "ETA    --    ");
}

// Two threads report progress while a bar is drawn (NONHOLO_PROGRESS=1 draws it without a
// terminal): under ThreadSanitizer (tools/sanitize.sh) this finds a read of the redraw time
// outside the mutex, as there was before it became atomic.
TEST(Progress, ThreadsUpdateItWithoutARace) {
  setenv("NONHOLO_PROGRESS", "1", 1);
  {
    scenarios::Progress progress("race check", 2'000'000);
    const auto until = std::chrono::steady_clock::now() + std::chrono::milliseconds(800);
    auto work = [&] {
      while (std::chrono::steady_clock::now() < until) progress.add(1);
    };
    std::thread a(work), b(work);
    a.join();
    b.join();
    progress.finish();
  }
  unsetenv("NONHOLO_PROGRESS");
}

// A file already at OUT.partial.csv (a journal left by a batch that did not finish, a user's
// file, or a link) was emptied, then removed at the end. Now the batch refuses it, names it and
// leaves it, the link's target and an existing --out as they were, with no temporary behind.
TEST(BatchCommand, AFileWhereTheJournalGoesIsRefusedAndKept) {
  namespace fs = std::filesystem;
  const std::string out = temp("kept.csv"), journal = out + ".partial.csv", target = temp("kept_target.txt");
  std::ofstream(out) << "precious table";
  for (bool link : {false, true}) {
    fs::remove(journal);
    fs::remove(target);
    if (link) {
      fs::create_symlink(target, journal);  // dangling: O_CREAT would have made the target
    } else {
      std::ofstream(journal) << "rows of an earlier batch";
    }
    const Cli r = cli({"batch", "sleigh", "--count", "2", "--t-end", "0.5", "--out", out});
    EXPECT_EQ(r.code, 1) << r.err;
    EXPECT_THAT(r.err, ::testing::HasSubstr("'" + journal + "' exists: the journal of an earlier batch"));
    EXPECT_THAT(r.err, ::testing::HasSubstr("move or remove it"));
    EXPECT_EQ(slurp(out), "precious table");
    if (link) {
      EXPECT_TRUE(fs::is_symlink(journal));
      EXPECT_FALSE(fs::exists(target));
    } else {
      EXPECT_EQ(slurp(journal), "rows of an earlier batch");
    }
    for (const auto& e : fs::directory_iterator(fs::path(out).parent_path()))
      EXPECT_NE(e.path().filename().string().rfind("." + fs::path(out).filename().string() + ".", 0), 0u)
          << "a temporary left behind: " << e.path();
  }
  fs::remove(journal);
  const Cli ok = cli({"batch", "sleigh", "--count", "2", "--t-end", "0.5", "--out", out});
  EXPECT_EQ(ok.code, 0) << ok.err;
  EXPECT_EQ(slurp(out).rfind("trajectory,", 0), 0u);
  EXPECT_FALSE(fs::exists(journal));
  fs::remove(out);
  // A directory as --out: refused before the trajectories run, as opening it for writing was.
  fs::create_directory(out);
  const Cli dir = cli({"batch", "sleigh", "--count", "2", "--t-end", "0.5", "--out", out});
  EXPECT_EQ(dir.code, 1);
  EXPECT_THAT(dir.err, ::testing::HasSubstr("cannot open '" + out + "' for writing: it is a directory"));
  fs::remove(out);
}

// The journal of finished rows (OUT.partial.csv) takes no lock per row: each thread appends its
// rows in blocks. Eight threads add 4000 rows at once; the file must hold the header, then
// exactly the lines the batch's table writes for the same rows (in any order), none torn or
// interleaved.
TEST(Journal, RowsFromManyThreadsLandWhole) {
  const std::string out = temp("journal.csv"), journal = out + ".partial.csv";
  constexpr int kThreads = 8, kRows = 500;
  scenarios::BatchResult table;
  table.varied = {"omega0"};
  table.shown = {"x", "y", "theta"};
  for (int i = 0; i < kThreads * kRows; ++i) {
    scenarios::RunSummary s;
    s.t_final = 10.0 + i;
    s.energy_rel_err_max = 1e-7 * i;
    s.restarts = i % 7;
    table.rows.push_back({{0.125 * i}, {std::sqrt(double(i)), -1.0 / (i + 1), 3.0 * i}, s});
  }
  {
    scenarios::Journal j(out, nullptr, false);
    j.begin(kThreads);
    std::vector<std::thread> threads;
    for (int t = 0; t < kThreads; ++t)
      threads.emplace_back([&, t] {
        for (int k = 0; k < kRows; ++k) {
          const long i = static_cast<long>(k) * kThreads + t;
          j.add(i, t, table.rows[static_cast<std::size_t>(i)], table.varied, table.shown);
        }
      });
    for (auto& t : threads) t.join();
    j.flush();
    std::ifstream written(journal);
    std::vector<std::string> got;
    for (std::string line; std::getline(written, line);) got.push_back(line);
    std::ofstream whole(out);
    scenarios::write_batch_csv(whole, out, table, false);
    std::ifstream expected_file(out);
    std::vector<std::string> expected;
    for (std::string line; std::getline(expected_file, line);) expected.push_back(line);
    ASSERT_EQ(got.size(), expected.size());
    EXPECT_EQ(got.front(), expected.front());  // the header first
    std::sort(got.begin() + 1, got.end());
    std::sort(expected.begin() + 1, expected.end());
    EXPECT_EQ(got, expected);
    j.remove();
  }
  EXPECT_FALSE(std::filesystem::exists(journal));
  std::remove(out.c_str());
}

// A thread's rows reach the file without a flush (what a kill -9 leaves), also while the thread
// is busy with a long trajectory: one row added, then the file polled (the flusher writes it
// once it is Journal::kJournalDelay old).
TEST(Journal, RowsReachTheFileWithoutAFlush) {
  const std::string out = temp("journal_delay.csv"), journal = out + ".partial.csv";
  scenarios::BatchResult::Trajectory row{{1.0}, {2.0, 3.0, 4.0}, {}};
  scenarios::Journal j(out, nullptr, false);
  j.begin(2);
  auto rows_in_file = [&] {
    std::ifstream in(journal);
    long lines = 0;
    for (std::string line; std::getline(in, line);) ++lines;
    return lines - 1;  // the header
  };
  j.add(0, 1, row, {"v"}, {"x", "y", "z"});
  j.add(1, 1, row, {"v"}, {"x", "y", "z"});
  EXPECT_LE(rows_in_file(), 2);
  const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(30);
  while (rows_in_file() < 2 && std::chrono::steady_clock::now() < give_up)
    std::this_thread::sleep_for(std::chrono::milliseconds(1));  // polled, not waited on
  EXPECT_EQ(rows_in_file(), 2);
  j.remove();
  std::remove(out.c_str());
}

// Ctrl-C: the run stops between steps, the CSV ends with a whole row, the summary is printed
// with status=interrupted, and the exit code is 130 (128 + SIGINT).
TEST(Interrupt, RunStopsCleanlyWithAValidCsvAndSummary) {
  const std::string csv = temp("interrupted.csv"), out = temp("interrupted.out");
  const std::string cmd = "timeout --preserve-status -s INT 1 " + std::string(NONHOLO_CLI) +
                          " run sleigh_chain --set bodies=2000 --t-end 1e5 --out " + csv + " > " + out + " 2>&1";
  const int rc = std::system(cmd.c_str());
  ASSERT_TRUE(WIFEXITED(rc));
  EXPECT_EQ(WEXITSTATUS(rc), 130);
  const std::string text = slurp(out);
  EXPECT_THAT(text, ::testing::HasSubstr("status=interrupted"));
  EXPECT_THAT(text, ::testing::HasSubstr("interrupted (SIGINT) after step"));
  const std::string rows = slurp(csv);
  ASSERT_FALSE(rows.empty());
  EXPECT_EQ(rows.back(), '\n') << "the last row is whole";
  // Every row has as many fields as the header.
  std::istringstream lines(rows);
  std::string line, header;
  std::getline(lines, header);
  const auto fields = [](const std::string& l) { return std::count(l.begin(), l.end(), ','); };
  long count = 0;
  while (std::getline(lines, line)) {
    ASSERT_EQ(fields(line), fields(header)) << "row " << count;
    ++count;
  }
  EXPECT_GT(count, 1);
  std::remove(csv.c_str());
  std::remove(out.c_str());
}

}  // namespace
}  // namespace nonholo
