// A model built in code runs through the scenes' run (run_model, docs/guide/library.md "Run a model"):
// for every built-in scene, its model run from its start gives the scene run's frames and summary
// bit for bit (one run loop: integrate_scene builds the model and calls the same one); a start
// from a State is the start from its velocity; a later start time ends at t_end; checkpoints of a
// model resume bit for bit and only with the same model; and the refusals.
#include <nonholo/scenarios/batch.hpp>
#include <nonholo/scenarios/command_line.hpp>
#include <nonholo/scenarios/run.hpp>
#include <nonholo/start.hpp>
#include <nonholo/workspace.hpp>

#include "support/expect_error.hpp"
#include "support/same_summary.hpp"
#include "support/temp_files.hpp"

#include <gtest/gtest.h>

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <memory>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

namespace nonholo::scenarios {
namespace {

namespace fs = std::filesystem;
using testing::expect_error;

using testing::bytes_of;
using testing::expect_same_summary;

std::string temp(const std::string& name) { return testing::temp_path("model", name); }

// Every frame's t, q and p; stops the run (as Ctrl-C would) after `stop_after` frames, if set.
class Frames final : public FrameSink {
 public:
  explicit Frames(long stop_after = -1) : stop_after_(stop_after) {}
  void begin(const std::vector<std::string>&) override {}
  void frame(double t, ConstVecRef q, ConstVecRef p, const Diagnostics&) override {
    values.push_back(t);
    values.insert(values.end(), q.data(), q.data() + q.size());
    values.insert(values.end(), p.data(), p.data() + p.size());
    ++count;
  }
  bool stop_requested() override { return stop_after_ >= 0 && count >= stop_after_; }
  std::vector<double> values;
  long count = 0;

 private:
  long stop_after_;
};

void expect_same_values(const std::vector<double>& a, const std::vector<double>& b, const std::string& label) {
  ASSERT_EQ(a.size(), b.size()) << label;
  EXPECT_EQ(std::memcmp(a.data(), b.data(), a.size() * sizeof(double)), 0) << label << ": the frames differ";
}

// The scene's model and start for these --set assignments.
SceneSetup build(const std::string& scene, const std::vector<std::string>& sets) {
  const SceneInfo& info = find_scene(scene);
  Parameters p = info.defaults();
  for (const auto& a : sets) p.assign(a);
  return info.build(p);
}

RunStart start_of(const SceneSetup& s) { return RunStart{s.t0, s.q0, s.v0, {}}; }

// `nonholo run ARGS` against run_model on the scene's model with the same options: the same
// frames and summary. Returns the scene run's summary.
RunSummary expect_model_runs_as_scene(const std::vector<std::string>& args, const std::string& label) {
  SCOPED_TRACE(label);
  RunConfig scene_config = parse_run_arguments(args);
  Frames scene_frames;
  scene_config.sink = &scene_frames;
  const RunSummary from_scene = run_scene(scene_config);

  std::vector<std::string> sets;
  for (const auto& a : scene_config.assignments) sets.push_back(a);
  const SceneSetup setup = build(scene_config.scene, sets);
  RunConfig model_config = scene_config;
  model_config.assignments.clear();
  const SceneInfo& info = find_scene(scene_config.scene);
  if (!(model_config.dt > 0.0)) model_config.dt = info.default_dt;
  if (model_config.t_end < 0.0) model_config.t_end = info.default_t_end;
  Frames model_frames;
  model_config.sink = &model_frames;
  const RunSummary from_model = run_model(setup.model, start_of(setup), model_config);
  expect_same_summary(from_scene, from_model, label);
  expect_same_values(scene_frames.values, model_frames.values, label);
  EXPECT_GT(scene_frames.count, 2) << label;
  return from_scene;
}

TEST(RunModel, EveryBuiltInSceneRunsAsItsModel) {
  for (const SceneInfo& info : scene_catalogue()) {
    // 40 steps of the scene's default (and every output frame), the accuracy check's companion on.
    std::ostringstream t_end;
    t_end.precision(17);
    t_end << 40.0 * info.default_dt;
    expect_model_runs_as_scene({info.name, "--t-end", t_end.str()}, info.name);
  }
}

TEST(RunModel, MethodsOrdersAndChecksRunAsTheScene) {
  const std::vector<std::vector<std::string>> cases{
      {"sleigh_chain", "--set", "bodies=5", "--method", "rk4", "--t-end", "2"},
      {"sleigh_chain", "--set", "bodies=5", "--method", "dla-midpoint", "--t-end", "2"},
      {"sleigh_chain", "--set", "bodies=5", "--method", "arkode-dp5", "--tol", "1e-8", "--t-end", "2"},
      {"sleigh_chain", "--set", "bodies=5", "--order", "4", "--dt", "0.05", "--t-end", "2"},
      {"sleigh_chain", "--set", "bodies=5", "--order", "6", "--tol", "1e-8", "--dt", "0.5", "--t-end", "5"},
      {"sleigh_chain", "--set", "bodies=5", "--hitch", "oneform", "--threads", "2", "--t-end", "2"},
      {"sleigh_chain", "--set", "bodies=5", "--error-estimate", "--every", "7", "--t-end", "2"},
      {"wheeled_train", "--set", "bodies=5", "--accuracy-check", "sampled", "--t-end", "2"},
  };
  for (const auto& args : cases) {
    std::string label;
    for (const auto& a : args) label += a + " ";
    expect_model_runs_as_scene(args, label);
  }
}

// A 5-body chain on a step too large for its accuracy: inaccurate, as the scene run says, and
// rightly: at the times of its frames its configurations are off those of steps 100 times shorter
// by more than the accuracy check's tolerance (a tenth of the extent).
TEST(RunModel, ATooLargeStepEndsInaccurateAsTheScene) {
  const RunSummary s = expect_model_runs_as_scene(
      {"sleigh_chain", "--set", "bodies=5", "--set", "omega0=5", "--dt", "0.1", "--t-end", "20"}, "dt 0.1");
  EXPECT_EQ(s.status, Status::Inaccurate) << s.line() << " " << s.message;
  const SceneSetup setup = build("sleigh_chain", {"bodies=5", "omega0=5"});
  auto frames_of = [&](double dt, long every) {
    RunConfig c;
    c.dt = dt;
    c.t_end = 20.0;
    c.every = every;
    c.accuracy = 0.0;
    Frames frames;
    c.sink = &frames;
    EXPECT_EQ(run_model(setup.model, start_of(setup), c).status, Status::Ok);
    return frames;
  };
  const Frames run = frames_of(0.1, 1), reference = frames_of(0.001, 100);
  ASSERT_EQ(run.count, reference.count);
  const std::size_t n = static_cast<std::size_t>(setup.model.num_configuration());
  const std::size_t width = 1 + n + static_cast<std::size_t>(setup.model.num_velocities());
  double error = 0.0;
  for (std::size_t f = 0; f < run.values.size(); f += width)
    for (std::size_t i = 1; i <= n; ++i) error = std::max(error, std::abs(run.values[f + i] - reference.values[f + i]));
  EXPECT_GT(error, 0.1 * s.extent) << "the run was accurate after all";
}

// start_from_velocity's state handed over is the same start: the same run, bit for bit (the
// reflection method continues it; RK4 starts from its q and M^-1 p~).
TEST(RunModel, AStartFromAStateIsTheStartFromItsVelocity) {
  const SceneSetup setup = build("sleigh_chain", {"bodies=5"});
  for (const std::string method : {"reflection", "rk4"}) {
    SCOPED_TRACE(method);
    RunConfig config;
    config.method = method;
    config.dt = 0.01;
    config.t_end = 2.0;
    Frames a, b;
    config.sink = &a;
    const RunSummary from_velocity = run_model(setup.model, start_of(setup), config);
    Workspace ws(setup.model);
    RunStart from_state;
    from_state.state = start_from_velocity(setup.model, ws, setup.t0, setup.q0, setup.v0);
    config.sink = &b;
    const RunSummary from_given = run_model(setup.model, from_state, config);
    expect_same_summary(from_velocity, from_given, method);
    expect_same_values(a.values, b.values, method);
  }
}

// A start at t0 = 2 runs to t_end = 5 in 300 steps of 0.01: for this autonomous model the same
// configurations as the run from 0 to 3.
TEST(RunModel, ALaterStartEndsAtTEnd) {
  const SceneSetup setup = build("sleigh_chain", {"bodies=3"});
  RunConfig config;
  config.dt = 0.01;
  config.t_end = 3.0;
  Frames from_zero, from_two;
  config.sink = &from_zero;
  const RunSummary a = run_model(setup.model, start_of(setup), config);
  RunStart later = start_of(setup);
  later.t0 = 2.0;
  config.t_end = 5.0;
  config.sink = &from_two;
  const RunSummary b = run_model(setup.model, later, config);
  ASSERT_EQ(b.status, Status::Ok) << b.message;
  EXPECT_EQ(b.steps, 300);
  EXPECT_EQ(a.steps, 300);
  EXPECT_NEAR(b.t_final, 5.0, 1e-12);
  const std::size_t n = static_cast<std::size_t>(setup.model.num_configuration());
  const std::size_t width = 1 + n + static_cast<std::size_t>(setup.model.num_velocities());
  ASSERT_EQ(from_zero.values.size(), from_two.values.size());
  for (std::size_t f = 0; f < from_zero.values.size(); f += width) {
    EXPECT_NEAR(from_two.values[f] - from_zero.values[f], 2.0, 1e-12);
    EXPECT_EQ(std::memcmp(&from_zero.values[f + 1], &from_two.values[f + 1], n * sizeof(double)), 0)
        << "frame " << f / width;
  }
}

// A model's run stopped a third of the way with a checkpoint, resumed with the model: the
// uninterrupted run's output file and summary, bit for bit. Resumed with another model, or as a
// scene, it is refused; a scene's checkpoint is not a model's.
TEST(RunModel, ACheckpointResumesWithTheSameModelOnly) {
  const SceneSetup setup = build("sleigh_chain", {"bodies=5"});
  const std::string whole = temp("whole.csv"), part = temp("part.csv"), checkpoint = temp("ck.h5");
  RunConfig config;
  config.scene = "my_chain";
  config.dt = 0.01;
  config.t_end = 3.0;
  config.csv_path = whole;
  const RunSummary expected = run_model(setup.model, start_of(setup), config);
  ASSERT_EQ(expected.status, Status::Ok) << expected.message;
  EXPECT_EQ(expected.scene, "my_chain");

  config.csv_path = part;
  config.checkpoint_path = checkpoint;
  Frames stop(101);
  config.sink = &stop;
  const RunSummary first = run_model(setup.model, start_of(setup), config);
  ASSERT_EQ(first.status, Status::Interrupted) << first.message;

  RunConfig resume;
  resume.resume_path = checkpoint;
  expect_error([&] { run_scene(resume); }, "a model built in code (my_chain)");
  const SceneSetup other = build("sleigh_chain", {"bodies=6"});
  expect_error([&] { run_model(other.model, RunStart{}, resume); }, "the model is not the one the checkpoint");
  const SceneSetup heavier = build("sleigh_chain", {"bodies=5", "m=2"});
  expect_error([&] { run_model(heavier.model, RunStart{}, resume); }, "the model is not the one the checkpoint");
  const RunSummary resumed = run_model(setup.model, RunStart{}, resume);
  expect_same_summary(expected, resumed, "resumed");
  EXPECT_EQ(bytes_of(whole), bytes_of(part));

  // A scene's checkpoint resumed as a model.
  RunConfig scene_run = parse_run_arguments({"sleigh", "--t-end", "1", "--checkpoint", checkpoint});
  ASSERT_EQ(run_scene(scene_run).status, Status::Ok);
  expect_error([&] { run_model(setup.model, RunStart{}, resume); }, "the checkpoint is of the scene sleigh");
  for (const auto& f : {whole, part, checkpoint}) fs::remove(f);
}

TEST(RunModel, RefusesWhatItCannotRun) {
  const SceneSetup setup = build("sleigh_chain", {"bodies=2"});
  RunConfig ok;
  ok.dt = 0.01;
  ok.t_end = 1.0;
  auto with = [&](auto change) {
    RunConfig c = ok;
    change(c);
    return c;
  };
  const Model& model = setup.model;
  expect_error([&] { run_model(model, start_of(setup), with([](RunConfig& c) { c.dt = 0.0; })); },
               "--dt 0.000000: give the step (a model built in code has no default)");
  expect_error([&] { run_model(model, start_of(setup), with([](RunConfig& c) { c.t_end = -1.0; })); },
               "--t-end: give the end time");
  RunStart late = start_of(setup);
  late.t0 = 2.0;
  expect_error([&] { run_model(model, late, ok); }, "--t-end 1 is before the start's t0 = 2");
  expect_error([&] { run_model(model, start_of(setup), with([](RunConfig& c) { c.assignments = {"bodies=3"}; })); },
               "--set sets a scene's parameters");
  expect_error([&] { run_model(model, start_of(setup), with([](RunConfig& c) { c.scene = "chain.json"; })); },
               "a model built in code is run under a name");
  RunStart short_q = start_of(setup);
  short_q.q0.conservativeResize(2);
  expect_error([&] { run_model(model, short_q, ok); }, "start: expected 6 entries in q0");
  RunStart bad_state;
  bad_state.state = State();
  expect_error([&] { run_model(model, bad_state, ok); }, "the start's state has 0 configuration entries");
  expect_error([&] { run_model(model, start_of(setup), with([](RunConfig& c) { c.method = "euler"; })); },
               "unknown method 'euler'");
}

}  // namespace
}  // namespace nonholo::scenarios

namespace nonholo::scenarios {
namespace {

// A batch of a model built in code: each trajectory from the factory, called with its draws.
BatchConfig chain_batch(int threads) {
  BatchConfig config;
  config.run.scene = "chains";
  config.run.dt = 0.01;
  config.run.t_end = 2.0;
  config.count = 6;
  config.threads = threads;
  config.vary = {"turn=0.2:2"};
  config.seed = 5;
  config.keep_states = true;
  config.factory = [](const std::vector<double>& values, long) {
    std::ostringstream turn;
    turn.precision(17);
    turn << "omega0=" << values[0];
    SceneSetup s = build("sleigh_chain", {"bodies=3", turn.str()});
    return BatchModel{std::make_shared<const Model>(std::move(s.model)), RunStart{s.t0, s.q0, s.v0, {}}};
  };
  return config;
}

// The same trajectories as run one by one (run_model), bit for bit, on 1 and 2 threads.
TEST(RunModel, ABatchOfAFactoryIsItsTrajectoriesRunOneByOne) {
  const BatchResult one = run_batch(chain_batch(1)), two = run_batch(chain_batch(2));
  ASSERT_EQ(one.failed, 0) << one.first_failure;
  EXPECT_EQ(one.varied, std::vector<std::string>{"turn"});
  expect_same_values(one.states.q, two.states.q, "1 and 2 threads");
  expect_same_values(one.states.p, two.states.p, "1 and 2 threads");
  const BatchConfig config = chain_batch(1);
  for (long i = 0; i < config.count; ++i) {
    const std::vector<double> values = batch_draws(config, i);
    EXPECT_EQ(values, one.rows[static_cast<std::size_t>(i)].values);
    const BatchModel made = config.factory(values, i);
    RunConfig single = config.run;
    single.threads = 1;
    Frames frames;
    single.sink = &frames;
    const RunSummary s = run_model(*made.model, made.start, single);
    const std::size_t nq = one.states.coordinates.size(), nv = one.states.velocities.size();
    const std::vector<double> last(frames.values.end() - static_cast<std::ptrdiff_t>(nq + nv), frames.values.end());
    const std::vector<double> q(one.states.q.begin() + static_cast<std::ptrdiff_t>(i * nq),
                                one.states.q.begin() + static_cast<std::ptrdiff_t>((i + 1) * nq));
    expect_same_values(std::vector<double>(last.begin(), last.begin() + static_cast<std::ptrdiff_t>(nq)), q,
                       "trajectory " + std::to_string(i));
    EXPECT_EQ(std::memcmp(&s.error_estimate, &one.rows[static_cast<std::size_t>(i)].summary.error_estimate,
                          sizeof(double)),
              0);
  }
  BatchConfig bad = chain_batch(1);
  bad.run.dt = 0.0;
  expect_error([&] { run_batch(bad); }, "--dt 0.000000: give the step");
}

}  // namespace
}  // namespace nonholo::scenarios
