// Batch throughput on two cores (issue 5). Each benchmark times, in alternation within one
// run, the batch with 1 and with 2 threads and a compute-only loop with 1 and 2 threads of the
// same granularity, and reports
//   speedup          batch time with 1 thread / with 2 threads
//   machine_speedup  the same for the compute-only loop (what this shared machine gives now)
//   fraction         speedup / machine_speedup (target >= 0.9)
// BatchedSleighStep reports the per-step cost of a batched single sleigh against the
// hand-written scalar sleigh step (scalar_sleigh.hpp) measured in the same run (target <= 2, issue 12).
// CommandBatch times `nonholo batch` itself (run_batch: each trajectory's scene, model, run loop,
// accuracy check, journal and table, as the command does) for 20 000 single sleighs and 2000
// ten-body chains of 1000 steps with --out, on 1 thread and on all cores, and one sleigh of
// 2 x 10^7 steps (run_scene), in alternation, and reports (issue 35; targets: per_step_ratio
// <= 1.5, scaling_ratio >= 0.9)
//   sleigh_speedup, chain_speedup  1 thread / all cores, each batch
//   scaling_ratio                  sleigh_speedup / chain_speedup
//   per_step_ratio                 ns per step of the sleigh batch on 1 thread / of the long run
//   setup_us                       the sleigh batch's mean set-up per trajectory (its setup_s)
//   machine_speedup                a compute-only loop's, 1 thread / all cores (this machine now)
#include <nonholo/batch.hpp>
#include <nonholo/scenarios/batch.hpp>
#include <nonholo/scenarios/run.hpp>
#include <nonholo/scenarios/scene.hpp>
#include <nonholo/start.hpp>

#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>
#include <thread>
#include <vector>

#include "scalar_sleigh.hpp"

namespace {

using namespace nonholo;
using Clock = std::chrono::steady_clock;

double seconds(const std::function<void()>& f) {
  const auto start = Clock::now();
  f();
  return std::chrono::duration<double>(Clock::now() - start).count();
}

struct Ensemble {
  scenarios::SceneSetup setup;
  std::vector<State> starts;
  Ensemble(const char* scene, int bodies, long count)
      : setup(build(scene, bodies)) {
    Workspace ws(setup.model);
    for (long i = 0; i < count; ++i) {
      Vector v0 = setup.v0;
      v0[2] = 0.5 + 1e-4 * static_cast<double>(i);  // turn rates spread over the ensemble
      starts.push_back(start_from_velocity(setup.model, ws, 0.0, setup.q0, v0));
    }
  }
  static scenarios::SceneSetup build(const char* scene, int bodies) {
    const auto& info = scenarios::find_scene(scene);
    auto p = info.defaults();
    if (bodies > 0) p.set("bodies", bodies);
    return info.build(p);
  }
};

// A compute-only loop of the same shape: count independent jobs of similar length.
double compute_only(long count, int threads, int work) {
  std::vector<double> sink(static_cast<std::size_t>(count));
  return seconds([&] {
    parallel_for(count, threads, [&](long i, int) {
      double x = static_cast<double>(i);
      for (int k = 0; k < work; ++k) x = std::sin(x) + 1e-3 * k;
      sink[static_cast<std::size_t>(i)] = x;
    });
  });
}

void batch_scaling(benchmark::State& state, const char* scene, int bodies, long count, long steps, int work) {
  Ensemble e(scene, bodies, count);
  const RattleOptions options{0.01};
  double t1 = 1e30, t2 = 1e30, c1 = 1e30, c2 = 1e30;
  for (auto _ : state) {
    for (int round = 0; round < 3; ++round) {
      for (int threads : {1, 2}) {
        std::vector<State> states = e.starts;
        BatchOptions b;
        b.threads = threads;
        const double t = seconds([&] { integrate_batch(e.setup.model, states, steps, options, b); });
        (threads == 1 ? t1 : t2) = std::min(threads == 1 ? t1 : t2, t);
        const double c = compute_only(count, threads, work);
        (threads == 1 ? c1 : c2) = std::min(threads == 1 ? c1 : c2, c);
      }
    }
  }
  state.counters["speedup"] = t1 / t2;
  state.counters["machine_speedup"] = c1 / c2;
  state.counters["fraction"] = (t1 / t2) / (c1 / c2);
  state.counters["ns_per_step_1thread"] = 1e9 * t1 / static_cast<double>(count * steps);
  state.counters["ns_per_step_2threads"] = 1e9 * t2 / static_cast<double>(count * steps);
}

void BatchScaling_Sleighs(benchmark::State& s) { batch_scaling(s, "sleigh", 0, 10000, 100, 300); }
void BatchScaling_Chains10(benchmark::State& s) { batch_scaling(s, "sleigh_chain", 10, 1000, 100, 3000); }

// One thread: the batched single-sleigh step against the scalar floor, in the same run.
void BatchedSleighStep(benchmark::State& state) {
  Ensemble e("sleigh", 0, 10000);
  const RattleOptions options{0.01};
  const long steps = 100;
  double batched = 1e30, scalar = 1e30;
  for (auto _ : state) {
    for (int round = 0; round < 3; ++round) {
      std::vector<State> states = e.starts;
      BatchOptions b;
      b.threads = 1;
      batched = std::min(batched, seconds([&] { integrate_batch(e.setup.model, states, steps, options, b); }));
      std::vector<bench::ScalarSleigh> floor;
      for (const State& s : e.starts) floor.push_back(bench::scalar_from(s));
      scalar = std::min(scalar, seconds([&] {
                          for (auto& s : floor)
                            for (long k = 0; k < steps; ++k) s.step();
                        }));
      benchmark::DoNotOptimize(floor.data());
    }
  }
  const double n = static_cast<double>(e.starts.size() * static_cast<std::size_t>(steps));
  state.counters["batched_ns_per_step"] = 1e9 * batched / n;
  state.counters["scalar_ns_per_step"] = 1e9 * scalar / n;
  state.counters["ratio"] = batched / scalar;
}

// `nonholo batch SCENE --count COUNT --threads THREADS --vary omega0=0.4:0.6 --out <temp>.csv`
// (t_end 10, dt 0.01: 1000 steps) with the given bodies, timed whole.
double command_batch(const char* scene, int bodies, long count, int threads, double* setup_s = nullptr) {
  scenarios::BatchConfig c;
  c.run.scene = scene;
  if (bodies > 0) c.run.assignments = {"bodies=" + std::to_string(bodies)};
  c.count = count;
  c.threads = threads;
  c.vary = {"omega0=0.4:0.6"};
  const auto out = std::filesystem::temp_directory_path() / "nonholo_bench_batch.csv";
  c.out = out.string();
  scenarios::BatchResult r;
  const double t = seconds([&] { r = scenarios::run_batch(c); });
  std::filesystem::remove(out);
  if (r.failed != 0) std::fprintf(stderr, "bench_batch: %ld trajectories failed\n", r.failed);
  if (setup_s) *setup_s = r.aggregate.setup_s;
  return t;
}

void CommandBatch(benchmark::State& state) {
  const int cores = std::max(2, static_cast<int>(std::thread::hardware_concurrency()));
  const long sleighs = 20000, chains = 2000, steps = 1000;
  double s1 = 1e30, sn = 1e30, c1 = 1e30, cn = 1e30, longest = 1e30, setup = 1e30, m1 = 1e30, mn = 1e30;
  for (auto _ : state) {
    for (int round = 0; round < 3; ++round) {
      double setup_s = 0.0;
      s1 = std::min(s1, command_batch("sleigh", 0, sleighs, 1, &setup_s));
      setup = std::min(setup, setup_s);
      sn = std::min(sn, command_batch("sleigh", 0, sleighs, cores));
      c1 = std::min(c1, command_batch("sleigh_chain", 10, chains, 1));
      cn = std::min(cn, command_batch("sleigh_chain", 10, chains, cores));
      scenarios::RunConfig one;
      one.scene = "sleigh";
      one.t_end = 0.01 * static_cast<double>(sleighs * steps);
      one.assignments = {"omega0=0.5"};
      longest = std::min(longest, seconds([&] { scenarios::run_scene(one); }));
      m1 = std::min(m1, compute_only(sleighs, 1, 3000));
      mn = std::min(mn, compute_only(sleighs, cores, 3000));
    }
  }
  state.counters["machine_speedup"] = m1 / mn;
  state.counters["threads"] = cores;
  state.counters["sleigh_speedup"] = s1 / sn;
  state.counters["chain_speedup"] = c1 / cn;
  state.counters["scaling_ratio"] = (s1 / sn) / (c1 / cn);
  state.counters["per_step_ratio"] = s1 / longest;
  state.counters["setup_us"] = 1e6 * setup;
  state.counters["sleigh_batch_ns_per_step"] = 1e9 * s1 / static_cast<double>(sleighs * steps);
}

}  // namespace

BENCHMARK(BatchScaling_Sleighs)->Iterations(1)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BatchScaling_Chains10)->Iterations(1)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BatchedSleighStep)->Iterations(1)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(CommandBatch)->Iterations(1)->Unit(benchmark::kMillisecond)->UseRealTime();

BENCHMARK_MAIN();
