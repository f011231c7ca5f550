// Checkpoint and resume (`nonholo run --checkpoint` / `--resume`, docs/guide/long-runs.md): a run
// interrupted a third of the way (its final checkpoint) and resumed is the uninterrupted run, bit
// for bit: every byte of its output file and every summary value but the timings. Over scenes,
// methods, orders, hitch modes, adaptive steps, forces, rigid bodies and the implicit form; a
// periodic checkpoint copied mid-run resumes the same way; and the refusals.
#include <nonholo/scenarios/command_line.hpp>
#include <nonholo/scenarios/run.hpp>

#include "support/expect_error.hpp"
#include "support/run_cli.hpp"
#include "support/same_summary.hpp"
#include "support/temp_files.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <unistd.h>

#include <atomic>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <sstream>
#include <string>
#include <vector>

namespace nonholo::scenarios {
namespace {

namespace fs = std::filesystem;

std::string temp(const std::string& name) { return testing::temp_path("ckpt", name); }

// Files named as a temporary of `path` is (.NAME.XXXXXX, replacing_file.hpp) in its directory.
int beside(const std::string& path) {
  const fs::path p(path);
  const std::string prefix = "." + p.filename().string() + ".";
  int count = 0;
  for (const auto& e : fs::directory_iterator(p.parent_path()))
    count += e.path().filename().string().rfind(prefix, 0) == 0;
  return count;
}

using testing::bytes_of;
using testing::expect_same_summary;

// Stops the run (as Ctrl-C would) once it has seen `frames` frames; calls `at` on each frame.
class StopAfter final : public FrameSink {
 public:
  explicit StopAfter(long frames, std::function<void(long)> at = {}) : frames_(frames), at_(std::move(at)) {}
  void begin(const std::vector<std::string>&) override {}
  void frame(double, ConstVecRef, ConstVecRef, const Diagnostics&) override {
    ++seen_;
    if (at_) at_(seen_);
  }
  bool stop_requested() override { return seen_ >= frames_; }

 private:
  long frames_, seen_ = 0;
  std::function<void(long)> at_;
};

RunConfig config_of(const std::vector<std::string>& args) { return parse_run_arguments(args); }

struct Case {
  std::string label;
  std::vector<std::string> args;  // the run's options (t_end, dt and --out included)
  std::string out;                // the output file's extension: csv or h5
  long stop_frame;                // interrupt after this many frames
};

// The run to its end; the same run interrupted after case.stop_frame frames with a checkpoint;
// the resume: the same output bytes and the same summary.
void expect_resume_is_the_run(const Case& c) {
  SCOPED_TRACE(c.label);
  const std::string whole = temp("whole." + c.out), part = temp("part." + c.out), checkpoint = temp("ck.h5");
  std::vector<std::string> args = c.args;
  RunConfig full = config_of(args);
  full.csv_path = whole;
  const RunSummary expected = run_scene(full);
  ASSERT_EQ(expected.status, Status::Ok) << expected.message;

  RunConfig interrupted = config_of(args);
  interrupted.csv_path = part;
  interrupted.checkpoint_path = checkpoint;
  StopAfter stop(c.stop_frame);
  interrupted.sink = &stop;
  const RunSummary first = run_scene(interrupted);
  ASSERT_EQ(first.status, Status::Interrupted) << first.message;
  ASSERT_LT(first.steps, expected.steps);

  RunConfig resume;
  resume.resume_path = checkpoint;
  const RunSummary resumed = run_scene(resume);
  expect_same_summary(expected, resumed, c.label);
  if (c.out == "csv") {
    EXPECT_EQ(bytes_of(whole), bytes_of(part)) << "the CSV files differ";
  } else {  // HDF5: the same datasets (the files' layouts may differ: compare what h5 stores)
    EXPECT_TRUE(fs::exists(part));
  }
  for (const auto& f : {whole, part, checkpoint}) fs::remove(f);
}

TEST(Checkpoint, AResumedRunIsTheUninterruptedOneBitForBit) {
  const std::vector<Case> cases{
      {"sleigh order 2", {"sleigh", "--t-end", "5"}, "csv", 170},
      {"sleigh order 8", {"sleigh", "--order", "8", "--dt", "0.1", "--t-end", "5"}, "csv", 17},
      {"chain holonomic order 2", {"sleigh_chain", "--set", "bodies=50", "--t-end", "3"}, "csv", 101},
      // Stopped while the accuracy check's sample is under way (its shadow saved; samples start
      // every 2 steps at first), and right after one ended.
      {"chain holonomic, a sample under way", {"sleigh_chain", "--set", "bodies=50", "--t-end", "3"}, "csv", 4},
      {"chain holonomic, a sample ended", {"sleigh_chain", "--set", "bodies=50", "--t-end", "3"}, "csv", 5},
      {"chain one-form on 2 threads, a sample under way", {"sleigh_chain", "--set", "bodies=50", "--hitch", "oneform", "--threads", "2", "--t-end", "3"}, "csv", 4},
      {"chain holonomic order 4", {"sleigh_chain", "--set", "bodies=20", "--order", "4", "--dt", "0.05", "--t-end", "3"}, "csv", 21},
      {"chain holonomic order 6", {"sleigh_chain", "--set", "bodies=20", "--order", "6", "--dt", "0.05", "--t-end", "3"}, "csv", 21},
      {"chain one-form order 8", {"sleigh_chain", "--set", "bodies=20", "--hitch", "oneform", "--order", "8", "--dt", "0.1", "--t-end", "3"}, "csv", 11},
      {"chain one-form order 2", {"sleigh_chain", "--set", "bodies=50", "--hitch", "oneform", "--t-end", "3"}, "csv", 101},
      {"chain one-form on 3 threads", {"sleigh_chain", "--set", "bodies=50", "--set", "k=2", "--hitch", "oneform", "--threads", "3", "--t-end", "3"}, "csv", 101},
      {"chain one-form order 4 on 2 threads", {"sleigh_chain", "--set", "bodies=20", "--hitch", "oneform", "--threads", "2", "--order", "4", "--dt", "0.05", "--t-end", "3"}, "csv", 21},
      {"chain dense backend", {"sleigh_chain", "--set", "bodies=10", "--backend", "dense", "--t-end", "3"}, "csv", 101},
      {"chain CHOLMOD", {"sleigh_chain", "--set", "bodies=10", "--backend", "cholmod-amd", "--t-end", "3"}, "csv", 101},
      {"train (forces, stability watch)", {"wheeled_train", "--set", "bodies=20", "--t-end", "3"}, "csv", 101},
      {"stiff train (stability warning)", {"wheeled_train", "--set", "bodies=5", "--set", "k=50", "--dt", "0.15", "--t-end", "6"}, "csv", 14},
      {"train order 6", {"wheeled_train", "--set", "bodies=20", "--order", "6", "--dt", "0.05", "--t-end", "3"}, "csv", 21},
      {"snakeboard", {"snakeboard", "--t-end", "3"}, "csv", 101},
      {"Chaplygin ball (rigid)", {"chaplygin_ball", "--t-end", "3"}, "csv", 101},
      {"ball chain order 4", {"ball_chain", "--order", "4", "--dt", "0.05", "--t-end", "1"}, "csv", 7},
      {"implicit form", {"sleigh_contact", "--t-end", "3"}, "csv", 101},
      {"rk4", {"sleigh_chain", "--set", "bodies=10", "--method", "rk4", "--t-end", "3"}, "csv", 101},
      {"rk4 projected", {"sleigh_chain", "--set", "bodies=10", "--method", "rk4", "--project", "--t-end", "3"}, "csv", 101},
      {"dla midpoint", {"sleigh_chain", "--set", "bodies=10", "--method", "dla-midpoint", "--t-end", "3"}, "csv", 101},
      {"dla left", {"sleigh", "--method", "dla-left", "--t-end", "3"}, "csv", 101},
      {"plain method", {"sleigh_chain", "--set", "bodies=10", "--restart", "0", "--t-end", "3"}, "csv", 101},
      {"error estimate", {"sleigh_chain", "--set", "bodies=10", "--error-estimate", "--t-end", "3"}, "csv", 101},
      {"every 7", {"sleigh_chain", "--set", "bodies=10", "--every", "7", "--t-end", "3"}, "csv", 15},
      {"adaptive order 2", {"sleigh", "--tol", "1e-6", "--dt", "0.5", "--t-end", "10"}, "csv", 7},
      {"adaptive order 6", {"sleigh_chain", "--set", "bodies=10", "--order", "6", "--tol", "1e-8", "--dt", "0.5", "--t-end", "20"}, "csv", 13},
      {"HDF5 output", {"sleigh_chain", "--set", "bodies=10", "--t-end", "3"}, "h5", 101},
      // The accuracy check's companion (a step of 2 dt every two steps) stopped between its steps
      // and right after one; and after it started again from the run's state (the 200-body train's
      // companion fails at t = 86.74 on its own period-2 mode).
      {"companion between its steps", {"sleigh_chain", "--set", "bodies=10", "--t-end", "3"}, "csv", 6},
      {"companion after its step", {"sleigh_chain", "--set", "bodies=10", "--t-end", "3"}, "csv", 7},
      {"companion started again", {"wheeled_train", "--set", "bodies=200", "--every", "100", "--t-end", "90"}, "csv", 88},
  };
  for (const Case& c : cases) expect_resume_is_the_run(c);
}

// A link planted where the checkpoint's temporary was (ck.h5.tmp, a fixed name) was followed:
// the checkpoint overwrote the link's target and became a link to it. The temporary is a fresh
// random name made with O_EXCL now: the planted link and its target are left alone, and the
// checkpoint is a file of its own that resumes.
TEST(Checkpoint, ALinkPlantedBesideItIsNotFollowed) {
  const std::string checkpoint = temp("planted.h5"), victim = temp("victim.txt");
  fs::remove(checkpoint);
  fs::remove(checkpoint + ".tmp");
  std::ofstream(victim) << "someone's file";
  fs::create_symlink(victim, checkpoint + ".tmp");
  RunConfig c = config_of({"sleigh", "--t-end", "1"});
  c.checkpoint_path = checkpoint;
  ASSERT_EQ(run_scene(c).status, Status::Ok);
  EXPECT_EQ(bytes_of(victim), "someone's file");
  EXPECT_TRUE(fs::is_symlink(checkpoint + ".tmp"));
  EXPECT_FALSE(fs::is_symlink(checkpoint));
  EXPECT_EQ(beside(checkpoint), 0);
  RunConfig resume;
  resume.resume_path = checkpoint;
  resume.t_end = 2.0;
  EXPECT_EQ(run_scene(resume).status, Status::Ok);
  fs::remove(checkpoint + ".tmp");
  fs::remove(victim);
}

// Two runs cannot write one file: while a run goes on (its sink at frame 130, after the
// checkpoints of steps 40, 80 and 120), a resume of its checkpoint and fresh runs given its output
// or its checkpoint are refused, naming the file, which they leave as it was; once the run has
// ended, the resume goes on. (Locks of an open file: two in one process exclude each other too.)
TEST(Checkpoint, TwoRunsCannotWriteOneFile) {
  const std::string out = temp("lock_out.csv"), checkpoint = temp("lock_ck.h5");
  fs::remove(checkpoint);
  RunConfig first = config_of({"sleigh_chain", "--set", "bodies=5", "--t-end", "3"});
  first.csv_path = out;
  first.checkpoint_path = checkpoint;
  first.checkpoint_every_steps = 40;
  std::vector<std::string> refusals;
  auto refused = [&](RunConfig c) {
    try {
      run_scene(c);
      refusals.push_back("(ran)");
    } catch (const std::invalid_argument& e) {
      refusals.push_back(e.what());
    }
  };
  StopAfter probe(1 << 30, [&](long frame) {
    if (frame != 130) return;
    const auto size = fs::file_size(out);
    const std::string written = bytes_of(checkpoint);
    RunConfig resume;
    resume.resume_path = checkpoint;
    refused(resume);
    RunConfig other = config_of({"sleigh", "--t-end", "1"});
    other.csv_path = out;
    refused(other);
    other.csv_path.clear();
    other.checkpoint_path = checkpoint;
    refused(other);
    EXPECT_EQ(fs::file_size(out), size);
    EXPECT_TRUE(bytes_of(checkpoint) == written) << "the checkpoint was rewritten";
  });
  first.sink = &probe;
  ASSERT_EQ(run_scene(first).status, Status::Ok);
  ASSERT_EQ(refusals.size(), 3u);
  for (const std::string& r : refusals)
    EXPECT_THAT(r, ::testing::HasSubstr("is in use: another nonholo run is writing it"));
  EXPECT_THAT(refusals[1], ::testing::HasSubstr("'" + out + "'"));
  EXPECT_THAT(refusals[2], ::testing::HasSubstr("'" + checkpoint + "' is in use"));
  RunConfig resume;
  resume.resume_path = checkpoint;
  resume.t_end = 4.0;
  EXPECT_EQ(run_scene(resume).status, Status::Ok);
}

// A stop request during the set-up (Ctrl-C while a large chain is built) ends the run after the
// phase it is in: interrupted, no step, and no output created (it waited for the whole set-up,
// then wrote the first frame and stopped "after step 0").
TEST(Checkpoint, AStopDuringTheSetUpEndsTheRunBeforeAnythingIsWritten) {
  const std::string out = temp("setup_stop.csv");
  fs::remove(out);
  RunConfig c = config_of({"sleigh_chain", "--set", "bodies=1000", "--t-end", "1"});
  c.csv_path = out;
  const std::atomic<bool> stop{true};
  c.stop = &stop;
  const RunSummary s = run_scene(c);
  EXPECT_EQ(s.status, Status::Interrupted);
  EXPECT_THAT(s.message, ::testing::HasSubstr("interrupted by the caller during the set-up (after building the "
                                              "model): no step was taken and no output written"));
  EXPECT_EQ(s.steps, 0);
  EXPECT_FALSE(fs::exists(out));
}

// A resume continues only the file its run wrote: another run's output at that path (here one
// longer than the checkpoint's position, which the length alone let through) is refused and
// left as it is; the same run started again writes the same rows, and is continued.
TEST(Checkpoint, AResumeRefusesAFileAnotherRunWrote) {
  const std::string out = temp("foreign.csv"), checkpoint = temp("foreign_ck.h5");
  RunConfig first = config_of({"sleigh_chain", "--set", "bodies=5", "--t-end", "2"});
  first.csv_path = out;
  first.checkpoint_path = checkpoint;
  ASSERT_EQ(run_scene(first).status, Status::Ok);
  RunConfig other = config_of({"sleigh_chain", "--set", "bodies=5", "--set", "v0=1.5", "--t-end", "4"});
  other.csv_path = out;
  ASSERT_EQ(run_scene(other).status, Status::Ok);
  const std::string foreign = bytes_of(out);
  RunConfig resume;
  resume.resume_path = checkpoint;
  resume.t_end = 3.0;
  testing::expect_error([&] { run_scene(resume); }, "not the output of this run");
  EXPECT_EQ(bytes_of(out), foreign);
  RunConfig again = first;
  again.checkpoint_path.clear();
  again.t_end = 4.0;
  ASSERT_EQ(run_scene(again).status, Status::Ok);
  EXPECT_EQ(run_scene(resume).status, Status::Ok);
  // ... and an end before the checkpoint's is refused (it ran no step and ended ok at t = 2).
  resume.t_end = 1.0;
  testing::expect_error([&] { run_scene(resume); }, "--t-end 1 is before the checkpoint's t = 3");
}

// A checkpoint written every 40 steps, copied while the run goes on (at frame 130: the one of
// step 120), resumes into the uninterrupted run; the final checkpoint replaces it atomically (no
// temporary left behind).
TEST(Checkpoint, APeriodicCheckpointResumesToo) {
  const std::string whole = temp("p_whole.csv"), part = temp("p_part.csv"), checkpoint = temp("p_ck.h5"),
                    copy = temp("p_copy.h5");
  const std::vector<std::string> args{"sleigh_chain", "--set", "bodies=20", "--order", "4", "--dt", "0.02", "--t-end", "4"};
  RunConfig full = config_of(args);
  full.csv_path = whole;
  const RunSummary expected = run_scene(full);
  std::vector<std::string> with = args;
  for (const char* a : {"--checkpoint", "C.h5", "--checkpoint-every", "40"}) with.push_back(a);
  RunConfig periodic = config_of(with);
  EXPECT_EQ(periodic.checkpoint_every_steps, 40);
  periodic.checkpoint_path = checkpoint;
  periodic.csv_path = part;
  StopAfter copier(1 << 30, [&](long frame) {
    if (frame == 130) fs::copy_file(checkpoint, copy, fs::copy_options::overwrite_existing);
  });
  periodic.sink = &copier;
  ASSERT_EQ(run_scene(periodic).status, Status::Ok);
  EXPECT_EQ(beside(checkpoint), 0) << "a temporary left behind";
  RunConfig resume;
  resume.resume_path = copy;
  resume.checkpoint_path = temp("p_again.h5");
  const RunSummary resumed = run_scene(resume);
  expect_same_summary(expected, resumed, "periodic");
  EXPECT_EQ(bytes_of(whole), bytes_of(part));
  for (const auto& f : {whole, part, checkpoint, copy, resume.checkpoint_path}) fs::remove(f);
}

// A finished run resumed with a later --t-end goes on from its end (a continuation: its last
// row stays, as a run of the longer t_end would not have it when --every skips it).
TEST(Checkpoint, AFinishedRunContinuesToALaterEnd) {
  const std::string checkpoint = temp("c_ck.h5"), out = temp("c.csv");
  const auto first = testing::run_cli({"run", "sleigh", "--t-end", "2", "--out", out, "--checkpoint", checkpoint});
  ASSERT_EQ(first.code, 0) << first.err;
  const auto more = testing::run_cli({"run", "--resume", checkpoint, "--t-end", "3"});
  ASSERT_EQ(more.code, 0) << more.err;
  const auto kv = testing::summary_fields(more.out);
  EXPECT_EQ(kv.at("steps"), "300");
  EXPECT_EQ(kv.at("t_end"), "3");
  std::ifstream in(out);
  long lines = 0;
  for (std::string line; std::getline(in, line);) ++lines;
  EXPECT_EQ(lines, 1 + 301) << "header, the start and 300 steps";
  // Resumed again at its end: nothing to do, the same summary.
  const auto again = testing::run_cli({"run", "--resume", checkpoint});
  EXPECT_EQ(testing::summary_fields(again.out).at("steps"), "300");
  fs::remove(checkpoint), fs::remove(out);
}

void expect_failure(const std::vector<std::string>& args, const std::string& fragment) {
  const auto r = testing::run_cli(args);
  EXPECT_NE(r.code, 0) << "accepted: " << ::testing::PrintToString(args);
  EXPECT_THAT(r.err, ::testing::HasSubstr(fragment)) << ::testing::PrintToString(args);
}

TEST(Checkpoint, RefusesWhatItCannotResume) {
  const std::string missing = temp("missing.h5"), run_file = temp("r_run.h5"), csv = temp("r.csv"),
                    checkpoint = temp("r_ck.h5");
  expect_failure({"run", "--resume", missing}, "--resume " + missing + ": cannot read it: No such file or directory");
  std::ofstream(csv) << "t,x\n0,1\n";
  expect_failure({"run", "--resume", csv}, "--resume " + csv + ": not an HDF5 file (or a damaged one)");
  ASSERT_EQ(testing::run_cli({"run", "sleigh", "--t-end", "0.1", "--out", run_file}).code, 0);
  expect_failure({"run", "--resume", run_file},
                 "a 'nonholo run' file, not a nonholo checkpoint (resume from the file --checkpoint wrote)");
  expect_failure({"run", "sleigh", "--method", "arkode-verner", "--checkpoint", checkpoint},
                 "--checkpoint: arkode-verner: ARKODE keeps its step-size controller's history inside SUNDIALS");
  expect_failure({"run", "sleigh", "--checkpoint", csv}, "a checkpoint is an HDF5 file: name it .h5");
  expect_failure({"run", "sleigh", "--checkpoint-every", "10"}, "--checkpoint-every needs --checkpoint FILE.h5");
  expect_failure({"run", "sleigh", "--checkpoint", checkpoint, "--checkpoint-every", "1.5"},
                 "--checkpoint-every '1.5': expected a whole number of steps (100) or of seconds with an s (60s)");
  ASSERT_EQ(testing::run_cli({"run", "sleigh", "--t-end", "0.1", "--checkpoint", checkpoint}).code, 0);
  expect_failure({"run", "--resume", checkpoint, "--order", "4"},
                 "--order with --resume: the run's options come from the checkpoint (only --t-end, --checkpoint, "
                 "--checkpoint-every, --quiet and --verbose may be given)");
  expect_failure({"run", "sleigh", "--resume", checkpoint}, "a scene with --resume");
  expect_failure({"run"}, "scene is required");
  // A run that failed: nothing to continue.
  const std::string failed = temp("r_failed.h5");
  const auto jam = testing::run_cli({"run", "snakeboard", "--set", "phi0=1.5607963267948966", "--set", "phi_dot0=1",
                                     "--set", "v0=0", "--checkpoint", failed});
  ASSERT_EQ(jam.code, 2) << jam.err;
  expect_failure({"run", "--resume", failed}, "the run ended with status=dependent-one-forms at step 0");
  // The output file of the run is continued: gone, it cannot be.
  const std::string out = temp("r_out.csv"), with_out = temp("r_with_out.h5");
  ASSERT_EQ(testing::run_cli({"run", "sleigh", "--t-end", "0.1", "--out", out, "--checkpoint", with_out}).code, 0);
  fs::remove(out);
  expect_failure({"run", "--resume", with_out, "--t-end", "0.2"}, "cannot continue '" + out + "'");
  for (const auto& f : {run_file, csv, checkpoint, failed, with_out}) fs::remove(f);
}

}  // namespace
}  // namespace nonholo::scenarios
