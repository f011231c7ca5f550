// Cost of one step of the built-in scenes, against the floor of docs/design.md section 7: a
// hand-written scalar step of the sleigh (a sin/cos and a dozen flops). Compare the
// sleigh's per-step time with ScalarSleighStep from the same run.
#include <nonholo/diagnostics.hpp>
#include <nonholo/rattle.hpp>
#include <nonholo/scenarios/scene.hpp>
#include <nonholo/start.hpp>

#include <benchmark/benchmark.h>

#include "scalar_sleigh.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <iostream>
#include <string>

namespace {

using namespace nonholo;
using bench::ScalarSleigh;
using bench::scalar_from;

struct Fixture {
  scenarios::SceneSetup setup;
  Workspace ws;
  State state;
  Fixture(const std::string& scene, sparse::Backend backend)
      : setup(scenarios::find_scene(scene).build(scenarios::find_scene(scene).defaults())),
        ws(setup.model, {backend}),
        state(start_from_velocity(setup.model, ws, 0.0, setup.q0, setup.v0)) {}
};

// restart: "auto" (the default options) or "plain" (the paper's method, the mode not measured).
void run_steps(benchmark::State& bench, const std::string& scene, sparse::Backend backend, bool diagnostics,
               const char* restart = "auto") {
  Fixture f(scene, backend);
  RattleOptions options{0.01};
  if (std::string(restart) == "plain") {
    options.restart.mode = RestartMode::Never;
    options.restart.monitor_every = 0;
  }
  for (auto _ : bench) {
    if (step(f.setup.model, f.ws, f.state, options) != Status::Ok) bench.SkipWithError(f.ws.message());
    if (diagnostics) benchmark::DoNotOptimize(diagnose(f.setup.model, f.ws, f.state, options.h));
    benchmark::DoNotOptimize(f.state.q.data());
  }
  bench.SetLabel(f.ws.backend_name());
}

void Step_Sleigh(benchmark::State& s) { run_steps(s, "sleigh", sparse::Backend::Auto, false); }
void Step_Sleigh_Plain(benchmark::State& s) { run_steps(s, "sleigh", sparse::Backend::Auto, false, "plain"); }
void Step_Particle(benchmark::State& s) { run_steps(s, "particle", sparse::Backend::Auto, false); }
void Step_Snakeboard(benchmark::State& s) { run_steps(s, "snakeboard", sparse::Backend::Auto, false); }
void Step_SleighCholmod(benchmark::State& s) { run_steps(s, "sleigh", sparse::Backend::CholmodAmd, false); }
void Step_SnakeboardCholmod(benchmark::State& s) { run_steps(s, "snakeboard", sparse::Backend::CholmodAmd, false); }
void StepAndDiagnose_Sleigh(benchmark::State& s) { run_steps(s, "sleigh", sparse::Backend::Auto, true); }


void ScalarSleighStep(benchmark::State& bench) {
  Fixture f("sleigh", sparse::Backend::Auto);
  ScalarSleigh s = scalar_from(f.state);
  for (auto _ : bench) {
    s.step();
    benchmark::DoNotOptimize(s);
  }
}

// The floor must compute the same thing as the library, or the comparison means nothing.
void check_floor_matches_library() {
  Fixture f("sleigh", sparse::Backend::Auto);
  ScalarSleigh s = scalar_from(f.state);
  for (int k = 0; k < 1000; ++k) {
    s.step();
    if (step(f.setup.model, f.ws, f.state, {0.01}) != Status::Ok) std::abort();
  }
  const double diff = std::abs(s.x - f.state.q[0]) + std::abs(s.y - f.state.q[1]) + std::abs(s.th - f.state.q[2]);
  if (!(diff < 1e-12)) {
    std::cerr << "scalar sleigh floor disagrees with the library by " << diff << "\n";
    std::abort();
  }
}

}  // namespace

BENCHMARK(ScalarSleighStep);
BENCHMARK(Step_Sleigh)->ComputeStatistics("min", [](const std::vector<double>& v) {
  return *std::min_element(v.begin(), v.end());
});
BENCHMARK(Step_Sleigh_Plain)->ComputeStatistics("min", [](const std::vector<double>& v) {
  return *std::min_element(v.begin(), v.end());
});
BENCHMARK(Step_SleighCholmod);
BENCHMARK(StepAndDiagnose_Sleigh);
BENCHMARK(Step_Particle);
BENCHMARK(Step_Snakeboard);
BENCHMARK(Step_SnakeboardCholmod);

int main(int argc, char** argv) {
  check_floor_matches_library();
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
