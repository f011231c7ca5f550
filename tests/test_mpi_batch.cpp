// `mpirun -n P nonholo batch` against one process (`nonholo batch` in-process): the same CSV
// byte for byte and the same summary line but for its timings and ranks=P, for 1, 2 and 3
// ranks; other ranks print nothing; trajectories refused on one rank do not stop the others;
// a rank that cannot begin does not leave the others waiting, nor one that fails after they
// began; ranks must run the same command; only `batch` is spread.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>
#include <string>
#include <sys/wait.h>
#include <unistd.h>
#include <vector>

#include "support/run_cli.hpp"

namespace nonholo {
namespace {

using ::testing::HasSubstr;

std::string temp(const std::string& name) {
  return (std::filesystem::temp_directory_path() / ("nonholo_mpi_" + std::to_string(::getpid()) + "_" + name)).string();
}

std::string slurp(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

struct Launch {
  int code;
  std::string out, err;
};

// `mpirun -n P --oversubscribe <nonholo> args...` (a hang fails after 120 s with code 124), with
// `env` (NAME=VALUE ...) set. OpenMPI refuses to start as root without the two variables.
Launch mpirun(int ranks, const std::string& args, const std::string& env = "") {
  const std::string out = temp("out.txt"), err = temp("err.txt");
  const std::string cmd = env + " OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 timeout 120 " + std::string(NONHOLO_MPIEXEC) + " -n " + std::to_string(ranks) +
                          " --oversubscribe " + NONHOLO_CLI + " " + args + " > " + out + " 2> " + err;
  const int status = std::system(cmd.c_str());
  Launch r{WIFEXITED(status) ? WEXITSTATUS(status) : -1, slurp(out), slurp(err)};
  std::remove(out.c_str());
  std::remove(err.c_str());
  return r;
}

// The same command in this process, without MPI.
testing::CliResult alone(const std::string& args) {
  std::istringstream in(args);
  std::vector<std::string> words;
  for (std::string w; in >> w;) words.push_back(w);
  return testing::run_cli(words);
}

// A summary line without what depends on the run (its timings) and on the launch (ranks=).
std::string comparable(const std::string& line) {
  static const std::regex timing(" (wall_s|setup_s|ns_per_step|ns_per_body_step|ranks)=[^ \n]*");
  return std::regex_replace(line, timing, "");
}

long lines(const std::string& text) { return std::count(text.begin(), text.end(), '\n'); }

// One process with `threads`, then P ranks with `rank_threads` each, the same batch: equal.
void expect_same(const std::string& batch, int threads, int ranks, int rank_threads, int code = 0) {
  const std::string single = temp("single.csv"), spread = temp("spread.csv");
  const auto one = alone(batch + " --threads " + std::to_string(threads) + " --out " + single);
  ASSERT_EQ(one.code, code) << one.err;
  EXPECT_THAT(one.out, ::testing::Not(HasSubstr("ranks="))) << "no ranks= without MPI";
  const Launch many = mpirun(ranks, batch + " --threads " + std::to_string(rank_threads) + " --out " + spread);
  EXPECT_EQ(many.code, code) << many.out << many.err;
  EXPECT_EQ(lines(many.out), 1) << "one summary line, from rank 0 only:\n" << many.out;
  EXPECT_THAT(many.out, HasSubstr(" ranks=" + std::to_string(ranks) + "\n"));
  EXPECT_EQ(comparable(many.out),
            comparable(std::regex_replace(one.out, std::regex("threads=\\d+"), "threads=" + std::to_string(rank_threads))));
  const std::string csv = slurp(single);
  EXPECT_GT(lines(csv), 1);
  EXPECT_EQ(slurp(spread), csv) << ranks << " ranks";
  std::remove(single.c_str());
  std::remove(spread.c_str());
}

const char* kChains = "batch sleigh_chain --count 12 --set bodies=5 --vary omega0=-1:1 --vary k=0:2 --t-end 2";

TEST(MpiBatch, OneRankIsOneProcess) { expect_same(kChains, 1, 1, 2); }
TEST(MpiBatch, TwoRanksAreOneProcess) { expect_same(kChains, 2, 2, 1); }
TEST(MpiBatch, ThreeRanksAreOneProcess) { expect_same(kChains, 3, 3, 2); }

// The summary's other fields: work, energy balance and the error estimate (a driven train), and
// a reference method's evaluations and momentum drift (snakeboard with RK4).
TEST(MpiBatch, EveryFieldComesBack) {
  expect_same("batch wheeled_train --count 6 --set bodies=3 --t-end 1 --error-estimate --vary force=0:1", 1, 2, 1);
  expect_same("batch snakeboard --count 5 --method rk4 --t-end 1 --vary v0=0.5:1", 2, 3, 1);
}

TEST(MpiBatch, RefusedTrajectoriesDoNotStopTheOthers) {
  // Masses drawn in [-0.5, 1.5]: trajectory 6 of seed 7 is refused at set-up, on whichever rank.
  const char* batch = "batch sleigh --count 10 --vary m=-0.5:1.5 --t-end 1 --seed 7";
  for (int ranks : {2, 3}) expect_same(batch, 2, ranks, 1, 2);
  const Launch r = mpirun(3, std::string(batch) + " --threads 1");
  const std::string failure = "nonholo batch: 1 of 10 trajectories failed; first: trajectory 6: sleigh: parameter m";
  EXPECT_THAT(r.err, HasSubstr(failure));
  EXPECT_EQ(r.err.find(failure), r.err.rfind(failure)) << "said once, by rank 0:\n" << r.err;
  EXPECT_THAT(r.out, HasSubstr("failed=1 ranks=3"));
}

TEST(MpiBatch, ARankThatCannotBeginStopsTheOthers) {
  // Rank 0 cannot write its output: said once, everyone stops.
  const Launch r = mpirun(2, "batch sleigh --count 4 --out /nonexistent/dir/x.csv");
  EXPECT_EQ(r.code, 1) << r.err;
  EXPECT_EQ(r.out, "");
  const std::string said = "nonholo batch: cannot open '/nonexistent/dir/x.csv' for writing";
  EXPECT_THAT(r.err, HasSubstr(said));
  EXPECT_EQ(r.err.find(said), r.err.rfind(said)) << r.err;
  // Rank 1 alone cannot read its scene (mpirun's MPMD form gives it other arguments): it says
  // why, rank 0 says which rank.
  const std::string cmd = "batch sleigh --count 4 : -n 1 " + std::string(NONHOLO_CLI) + " batch missing.json --count 4";
  const Launch m = mpirun(1, cmd);
  EXPECT_EQ(m.code, 1) << m.err;
  EXPECT_THAT(m.err, HasSubstr("nonholo batch: missing.json"));
  EXPECT_THAT(m.err, HasSubstr("nonholo batch: rank 1 of 2 could not begin the batch"));
}

// MPMD: rank 0 runs `batch sleigh --count 4 --t-end 1 <rank0>`, rank 1 `nonholo <rank1>`.
Launch two_commands(const std::string& rank0, const std::string& rank1) {
  return mpirun(1, "batch sleigh --count 4 --t-end 1 " + rank0 + " : -n 1 " + std::string(NONHOLO_CLI) + " " + rank1);
}

TEST(MpiBatch, RanksWithDifferentCommandsStopNamingTheDifference) {
  // Before: each rank ran its own draws and rank 0 wrote the mixed table, exit 0.
  const Launch r = two_commands("--vary v0=0:1", "batch sleigh --count 4 --t-end 1 --vary v0=5:6");
  EXPECT_EQ(r.code, 1) << r.err;
  EXPECT_EQ(r.out, "");
  const std::string said = "nonholo batch: the ranks were not started with the same batch: rank 0 has "
                           "vary=\"v0=0:1\", rank 1 has vary=\"v0=5:6\"";
  EXPECT_THAT(r.err, HasSubstr(said));
  EXPECT_EQ(r.err.find(said), r.err.rfind(said)) << "said once, by rank 0:\n" << r.err;
  // The same options in another order and form, and another --threads, are the same batch.
  const Launch same = two_commands("--vary v0=0:1 --threads 1", "batch sleigh --vary=v0=0:1 --t-end=1 --count 4");
  EXPECT_EQ(same.code, 0) << same.err;
  EXPECT_THAT(same.out, HasSubstr("failed=0 ranks=2"));
}

// Two ranks started in two directories with a scene file of the same name and other contents
// (as two machines would have): the options are equal, the files are not. Before: one mixed
// table, exit 0. Now refused naming the difference; the same contents agree.
TEST(MpiBatch, RanksWithDifferentSceneFilesOfOneNameStop) {
  const std::filesystem::path a = temp("scene_a"), b = temp("scene_b");
  std::filesystem::create_directories(a);
  std::filesystem::create_directories(b);
  const std::string scene = slurp(NONHOLO_SOURCE_DIR "/examples/scenes/towed_pair.json");
  std::ofstream(a / "s.json") << scene;
  std::string other = scene;
  other.replace(other.find("\"dt\": 0.01"), 10, "\"dt\": 0.02");
  std::ofstream(b / "s.json") << other;
  auto launch = [&](const std::filesystem::path& second) {
    const std::string out = temp("out.txt"), err = temp("err.txt");
    const std::string args = " batch s.json --count 4 --t-end 1";
    const std::string cmd = "cd " + a.string() + " && OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 timeout 120 " +
                            std::string(NONHOLO_MPIEXEC) + " -n 1 --oversubscribe " + NONHOLO_CLI + args + " : -n 1 -wdir " +
                            second.string() + " " + NONHOLO_CLI + args + " > " + out + " 2> " + err;
    const int status = std::system(cmd.c_str());
    Launch r{WIFEXITED(status) ? WEXITSTATUS(status) : -1, slurp(out), slurp(err)};
    std::remove(out.c_str());
    std::remove(err.c_str());
    return r;
  };
  const Launch r = launch(b);
  EXPECT_EQ(r.code, 1) << r.out << r.err;
  EXPECT_EQ(r.out, "");
  EXPECT_THAT(r.err, HasSubstr("the ranks were not started with the same batch: rank 0 has scene file s.json of "));
  std::ofstream(b / "s.json") << scene;  // the same bytes: one batch
  const Launch same = launch(b);
  EXPECT_EQ(same.code, 0) << same.err;
  EXPECT_THAT(same.out, HasSubstr("failed=0 ranks=2"));
  std::filesystem::remove_all(a);
  std::filesystem::remove_all(b);
}

TEST(MpiBatch, ARankThatReturnsBeforeTheBatchStopsTheOthers) {
  // Before: rank 1 returned and rank 0 waited for it forever (here: killed after 120 s, code 124).
  const Launch bad = two_commands("", "batch sleigh --count 4 --t-end 1 --bogus");
  EXPECT_EQ(bad.code, 1) << bad.err;
  EXPECT_THAT(bad.err, HasSubstr("The following argument was not expected: --bogus"));
  EXPECT_THAT(bad.err, HasSubstr("nonholo batch: rank 1 of 2 could not begin the batch"));
  const Launch other = two_commands("", "run sleigh --t-end 1");
  EXPECT_EQ(other.code, 1) << other.err;
  EXPECT_THAT(other.err, HasSubstr("nonholo run: only `batch` is spread over MPI ranks"));
  EXPECT_THAT(other.err, HasSubstr("nonholo batch: rank 1 of 2 could not begin the batch"));
  const Launch help = two_commands("", "batch --help");
  EXPECT_EQ(help.code, 1) << help.err;
  EXPECT_THAT(help.err, HasSubstr("nonholo batch: rank 1 of 2 could not begin the batch"));
}

TEST(MpiBatch, AFailureAfterTheRanksAgreedAbortsEveryRank) {
  // Rank 1 runs out of memory once the ranks have begun (the test hook of mpi_batch.cpp): the
  // others are in the ensemble's collectives and would wait for it forever.
  const Launch r = mpirun(3, "batch sleigh --count 6 --t-end 1", "NONHOLO_TEST_FAIL_RANK=1");
  EXPECT_NE(r.code, 0);
  EXPECT_NE(r.code, 124) << "a hang, killed by timeout";
  EXPECT_THAT(r.err, HasSubstr("nonholo batch: rank 1 of 3 failed during the batch: std::bad_alloc: stopping "
                               "every rank (MPI_Abort)"));
  EXPECT_EQ(r.out, "");
}

TEST(MpiBatch, OnlyBatchIsSpread) {
  const Launch two = mpirun(2, "run sleigh --t-end 1");
  EXPECT_EQ(two.code, 1);
  EXPECT_EQ(two.out, "");
  EXPECT_THAT(two.err, HasSubstr("nonholo run: only `batch` is spread over MPI ranks"));
  const Launch one = mpirun(1, "run sleigh --t-end 1");
  EXPECT_EQ(one.code, 0) << one.err;
  EXPECT_EQ(comparable(one.out), comparable(alone("run sleigh --t-end 1").out));
}

// Ctrl-C to mpirun, once some rows are done (the ranks' journals, OUT.partial.rankR.csv, have
// them): mpirun sends its ranks SIGTERM, they stop at their next step as one process stops on
// Ctrl-C, and rank 0 writes the table: every finished row is the one-process batch's, the others
// say interrupted, the summary is printed, the exit code is not 0; the journals are gone.
TEST(MpiBatch, CtrlCKeepsTheFinishedRowsLikeOneProcess) {
  const std::string batch = "batch sleigh_chain --count 90 --set bodies=150 --vary omega0=0.5:1.5 --t-end 60";
  const std::string spread = temp("ctrl_c.csv"), single = temp("ctrl_c_single.csv"), out = temp("ctrl_c_out.txt"),
                    err = temp("ctrl_c_err.txt"), pid = temp("ctrl_c.pid");
  const std::string cmd = "OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 " + std::string(NONHOLO_MPIEXEC) +
                          " -n 3 --oversubscribe " + NONHOLO_CLI + " " + batch + " --threads 1 --out " + spread + " > " +
                          out + " 2> " + err + " & echo $! > " + pid + "; wait $!; echo $? >> " + pid;
  std::FILE* shell = ::popen(cmd.c_str(), "r");
  ASSERT_NE(shell, nullptr);
  // Wait for finished rows in the journals (at most a minute), then Ctrl-C.
  long journaled = 0;
  for (int i = 0; i < 1200 && journaled < 6; ++i) {
    ::usleep(50000);
    journaled = 0;
    for (int r = 0; r < 3; ++r) journaled += std::max(0L, lines(slurp(spread + ".partial.rank" + std::to_string(r) + ".csv")) - 1);
  }
  std::istringstream ids(slurp(pid));
  long mpirun_pid = 0;
  ids >> mpirun_pid;
  ASSERT_GT(mpirun_pid, 0);
  ::kill(static_cast<pid_t>(mpirun_pid), SIGINT);
  ::pclose(shell);
  std::istringstream after(slurp(pid));
  long ignored = 0, code = -1;
  after >> ignored >> code;
  EXPECT_NE(code, 0) << slurp(err);  // mpirun exits 1 after a Ctrl-C whatever its ranks return
  const std::string printed = slurp(out);
  EXPECT_EQ(lines(printed), 1) << printed << slurp(err);
  EXPECT_THAT(printed, HasSubstr(" ranks=3"));
  EXPECT_THAT(slurp(err), HasSubstr("interrupted (SIGTERM)"));
  for (int r = 0; r < 3; ++r) EXPECT_FALSE(std::filesystem::exists(spread + ".partial.rank" + std::to_string(r) + ".csv"));
  // The finished rows against one process's batch of as many trajectories as reach the last of
  // them (a trajectory's row depends on the seed and its index only).
  std::istringstream cut(slurp(spread));
  std::vector<std::string> b;
  for (std::string line; std::getline(cut, line);) b.push_back(line);
  ASSERT_EQ(b.size(), 91u);
  auto interrupted = [](const std::string& row) {
    return row.size() >= 12 && row.compare(row.size() - 12, 12, ",interrupted") == 0;
  };
  long last = 0, finished = 0, stopped = 0;
  for (std::size_t i = 1; i < b.size(); ++i) {
    if (interrupted(b[i])) {
      ++stopped;
    } else {
      ++finished;
      last = static_cast<long>(i);
    }
  }
  EXPECT_GE(finished, 6) << "the rows journaled before Ctrl-C";
  EXPECT_GT(stopped, 0);
  const auto one = alone(std::regex_replace(batch, std::regex("--count 90"), "--count " + std::to_string(last)) +
                         " --threads 2 --out " + single);
  ASSERT_EQ(one.code, 0) << one.err;
  std::istringstream whole(slurp(single));
  std::vector<std::string> a;
  for (std::string line; std::getline(whole, line);) a.push_back(line);
  ASSERT_EQ(a.size(), static_cast<std::size_t>(last + 1));
  EXPECT_EQ(a[0], b[0]) << "the header";
  for (long i = 1; i <= last; ++i) {
    if (!interrupted(b[static_cast<std::size_t>(i)])) {
      EXPECT_EQ(a[static_cast<std::size_t>(i)], b[static_cast<std::size_t>(i)]) << "row " << i;
    }
  }
  for (const auto& f : {spread, single, out, err, pid}) std::remove(f.c_str());
}

}  // namespace
}  // namespace nonholo
