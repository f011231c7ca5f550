// Cost of the in-run accuracy check (nonholo/accuracy.hpp): steps with and without the watch,
// on the sleigh and on a 10^5-body chain, in one run (compare the pairs; docs/guide/methods.md
// "Accuracy check" has the ratios). The state runs on from iteration to iteration, so the watch samples
// as it does in a long run (dense at the start, then every 32 steps while samples agree).
#include <nonholo/accuracy.hpp>
#include <nonholo/rattle.hpp>
#include <nonholo/scenarios/scene.hpp>
#include <nonholo/start.hpp>

#include <benchmark/benchmark.h>

#include <memory>
#include <string>
#include <vector>

namespace {

using namespace nonholo;

void run(benchmark::State& bench, const std::string& scene, const std::vector<std::string>& sets, bool watched,
         int every = 64) {
  const auto& info = scenarios::find_scene(scene);
  auto params = info.defaults();
  for (const auto& s : sets) params.assign(s);
  const auto setup = info.build(params);
  RattleOptions o{0.01};
  Workspace ws(setup.model, {sparse::Backend::Auto, false, false});
  State s = start_from_velocity(setup.model, ws, setup.t0, setup.q0, setup.v0);
  std::unique_ptr<AccuracyWatch> watch;
  if (watched) watch = std::make_unique<AccuracyWatch>(ws, o, every);  // on the run's workspace, as nonholo run
  for (auto _ : bench) {
    if (watch) watch->before_step(s);
    if (step(setup.model, ws, s, o) != Status::Ok) bench.SkipWithError(ws.message());
    if (watch) watch->after_step(s);
    benchmark::DoNotOptimize(s.q.data());
  }
  if (watch) bench.counters["samples_per_step"] = static_cast<double>(watch->estimate().samples()) / static_cast<double>(bench.iterations());
}

void Accuracy_Sleigh_Off(benchmark::State& s) { run(s, "sleigh", {}, false); }
void Accuracy_Sleigh_On(benchmark::State& s) { run(s, "sleigh", {}, true); }
void Accuracy_Sleigh_On128(benchmark::State& s) { run(s, "sleigh", {}, true, 128); }
void Accuracy_Chain1e5_Off(benchmark::State& s) { run(s, "sleigh_chain", {"bodies=100000"}, false); }
void Accuracy_Chain1e5_On(benchmark::State& s) { run(s, "sleigh_chain", {"bodies=100000"}, true); }

}  // namespace

// Interleaved: each pair runs back to back (the machine is shared; ratios within a run count).
BENCHMARK(Accuracy_Sleigh_Off)->Iterations(2000000);
BENCHMARK(Accuracy_Sleigh_On)->Iterations(2000000);
BENCHMARK(Accuracy_Sleigh_On128)->Iterations(2000000);
BENCHMARK(Accuracy_Chain1e5_Off)->Iterations(2000)->Unit(benchmark::kMillisecond);
BENCHMARK(Accuracy_Chain1e5_On)->Iterations(2000)->Unit(benchmark::kMillisecond);

BENCHMARK_MAIN();
