// Set-up of a large chain (issue 35, docs/design.md section 7 "Set-up"): what `nonholo run sleigh_chain
// --set bodies=N` does before its first step, timed by phase (the scene's model, the run's workspace,
// the start projected onto the constraints, the accuracy check's shadow) with the memory it holds
// then, at N = 10^3 ... 10^6 (10^7 with NONHOLO_SETUP_1E7=1: 12 GB), in both hitch modes. Beside
// it the machine's own cost of touching fresh memory, with 4 kB pages and with huge pages, measured
// in the same run: on a virtual machine that is most of a large set-up, and it moves from day to day.
#include <nonholo/accuracy.hpp>
#include <nonholo/rattle.hpp>
#include <nonholo/scenarios/scene.hpp>
#include <nonholo/start.hpp>

#include <benchmark/benchmark.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <optional>
#include <string>

#if defined(__linux__)
#include <sys/mman.h>
#endif
#if defined(__GLIBC__)
#include <malloc.h>
#endif

namespace {

using namespace nonholo;
using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

// Bytes the process's heap holds (glibc: small blocks and mapped ones). The peak resident size of
// a run in a fresh process is the command line's to measure (/usr/bin/time): in this process the
// memory a larger set-up freed is reused by the next.
double heap_bytes() {
#if defined(__GLIBC__)
  const struct mallinfo2 m = mallinfo2();
  return static_cast<double>(m.uordblks + m.hblkhd);
#else
  return 0.0;
#endif
}

// One set-up as `nonholo run` does it on one thread (the reflection runner's workspace: no composed
// steps, no DLA copy), then one step; counters per phase, the memory the run holds after its set-up
// (model, start, workspace, the accuracy check's shadow) and per body.
void Setup_SleighChain(benchmark::State& bench, const char* hitch) {
  const long bodies = bench.range(0);
  const auto& info = scenarios::find_scene("sleigh_chain");
  auto params = info.defaults();
  params.assign("bodies=" + std::to_string(bodies));
  RattleOptions o;
  o.hitch = std::string(hitch) == "oneform" ? HitchMode::OneForm : HitchMode::Holonomic;
  WorkspaceOptions wo;
  wo.composed_steps = wo.dla_steps = false;
  double scene_s = 0, workspace_s = 0, start_s = 0, watch_s = 0, step_s = 0, held = 0;
  for (auto _ : bench) {
    const double before = heap_bytes();
    const auto t0 = Clock::now();
    std::optional<scenarios::SceneSetup> setup(info.build(params));
    const auto t1 = Clock::now();
    std::optional<Workspace> ws(std::in_place, setup->model, wo);
    const auto t2 = Clock::now();
    State s = start_from_velocity(setup->model, *ws, setup->t0, setup->q0, setup->v0);
    const auto t3 = Clock::now();
    AccuracyWatch watch(*ws, o, 64);
    watch.prepare();
    const double total = seconds_since(t0);
    const auto t4 = Clock::now();
    held += heap_bytes() - before;
    watch.before_step(s);
    if (step(setup->model, *ws, s, o) != Status::Ok) bench.SkipWithError(ws->message());
    watch.after_step(s);
    step_s += seconds_since(t4);
    bench.SetIterationTime(total);
    scene_s += std::chrono::duration<double>(t1 - t0).count();
    workspace_s += std::chrono::duration<double>(t2 - t1).count();
    start_s += std::chrono::duration<double>(t3 - t2).count();
    watch_s += std::chrono::duration<double>(t4 - t3).count();
  }
  const double n = static_cast<double>(bench.iterations());
  bench.counters["bodies"] = static_cast<double>(bodies);
  bench.counters["scene_s"] = scene_s / n;
  bench.counters["workspace_s"] = workspace_s / n;
  bench.counters["start_s"] = start_s / n;
  bench.counters["watch_s"] = watch_s / n;
  bench.counters["first_step_s"] = step_s / n;
  bench.counters["setup_per_step"] = (scene_s + workspace_s + start_s + watch_s) / step_s;
  bench.counters["held_MB"] = held / n / 1e6;
  bench.counters["bytes_per_body"] = held / n / static_cast<double>(bodies);
}

void Setup_OneForm(benchmark::State& s) { Setup_SleighChain(s, "oneform"); }
void Setup_Holonomic(benchmark::State& s) { Setup_SleighChain(s, "holonomic"); }

// Seconds per GB of touching memory the process never had: a fresh anonymous mapping written once
// (the kernel's page faults and zeroing, and a hypervisor's), with 4 kB pages and with transparent
// huge pages asked for (madvise); then written again (the memory bandwidth alone).
void Setup_FirstTouch(benchmark::State& bench) {
#if defined(__linux__) && defined(MADV_HUGEPAGE)
  const bool huge = bench.range(0) != 0;
  const std::size_t bytes = std::size_t{1} << 30;
  double first = 0, again = 0;
  for (auto _ : bench) {
    void* p = mmap(nullptr, bytes, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
    if (p == MAP_FAILED) {
      bench.SkipWithError("mmap failed");
      break;
    }
    if (huge) madvise(p, bytes, MADV_HUGEPAGE);
    auto t = Clock::now();
    std::memset(p, 1, bytes);
    const double f = seconds_since(t);
    t = Clock::now();
    std::memset(p, 2, bytes);
    again += seconds_since(t);
    first += f;
    benchmark::DoNotOptimize(static_cast<char*>(p)[bytes / 2]);
    munmap(p, bytes);
    bench.SetIterationTime(f);
  }
  bench.counters["first_s_per_GB"] = first / static_cast<double>(bench.iterations()) * 1.073741824;
  bench.counters["again_s_per_GB"] = again / static_cast<double>(bench.iterations()) * 1.073741824;
#else
  bench.SkipWithError("Linux only");
#endif
}

void sizes(benchmark::internal::Benchmark* b) {
  for (long n : {1000L, 10000L, 100000L, 1000000L}) b->Arg(n);
  if (const char* e = std::getenv("NONHOLO_SETUP_1E7"); e && std::string(e) == "1") b->Arg(10000000L);
  b->UseManualTime()->Unit(benchmark::kMillisecond)->Iterations(1);
}

BENCHMARK(Setup_FirstTouch)->Arg(0)->Arg(1)->UseManualTime()->Unit(benchmark::kMillisecond)->Iterations(3);
BENCHMARK(Setup_OneForm)->Apply(sizes);
BENCHMARK(Setup_Holonomic)->Apply(sizes);

}  // namespace

BENCHMARK_MAIN();
