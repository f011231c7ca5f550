// Cost of one step of the built-in scenes, against the floor of DESIGN.md section 7: a
// hand-written scalar step of the sleigh (a sin/cos and a dozen flops). Compare the
// sleigh's per-step time with ScalarSleighStep from the same run.
#include <nonholo/diagnostics.hpp>
#include <nonholo/rattle.hpp>
#include <nonholo/scenarios/scene.hpp>
#include <nonholo/start.hpp>

#include <benchmark/benchmark.h>

#include <cmath>
#include <cstdlib>
#include <iostream>

namespace {

using namespace nonholo;

struct Fixture {
  scenarios::SceneSetup setup;
  Workspace ws;
  State state;
  Fixture(const std::string& scene, sparse::Backend backend)
      : setup(scenarios::find_scene(scene).build(scenarios::find_scene(scene).defaults())),
        ws(setup.model, {backend}),
        state(start_from_velocity(setup.model, ws, 0.0, setup.q0, setup.v0)) {}
};

void run_steps(benchmark::State& bench, const std::string& scene, sparse::Backend backend, bool diagnostics) {
  Fixture f(scene, backend);
  const RattleOptions options{0.01};
  for (auto _ : bench) {
    if (step(f.setup.model, f.ws, f.state, options) != Status::Ok) bench.SkipWithError(f.ws.message());
    if (diagnostics) benchmark::DoNotOptimize(diagnose(f.setup.model, f.ws, f.state, options.h));
    benchmark::DoNotOptimize(f.state.q.data());
  }
  bench.SetLabel(f.ws.backend_name());
}

void Step_Sleigh(benchmark::State& s) { run_steps(s, "sleigh", sparse::Backend::Auto, false); }
void Step_Particle(benchmark::State& s) { run_steps(s, "particle", sparse::Backend::Auto, false); }
void Step_Snakeboard(benchmark::State& s) { run_steps(s, "snakeboard", sparse::Backend::Auto, false); }
void Step_SleighCholmod(benchmark::State& s) { run_steps(s, "sleigh", sparse::Backend::CholmodAmd, false); }
void Step_SnakeboardCholmod(benchmark::State& s) { run_steps(s, "snakeboard", sparse::Backend::CholmodAmd, false); }
void StepAndDiagnose_Sleigh(benchmark::State& s) { run_steps(s, "sleigh", sparse::Backend::Auto, true); }

// The floor: the same scheme for the sleigh written out with scalars.
struct ScalarSleigh {
  double m, inertia, a, h;
  double x, y, th, px, py, pth, fx, fy, fth;
  void step() {
    const double hh = 0.5 * h;
    const double qx = px + hh * fx, qy = py + hh * fy, qth = pth + hh * fth;  // p_{k+1/2}
    const double vx = qx / m, vy = qy / m, vth = qth / inertia;
    x += h * vx;
    y += h * vy;
    th += h * vth;
    const double s = std::sin(th), c = std::cos(th);
    const double gram = 1.0 / m + a * a / inertia;  // s^2 + c^2 = 1 folded in
    const double lambda = -(2.0 / h) * (s * vx - c * vy + a * vth) / gram;
    fx = s * lambda;
    fy = -c * lambda;
    fth = a * lambda;
    px = qx + hh * fx;
    py = qy + hh * fy;
    pth = qth + hh * fth;
  }
};

ScalarSleigh scalar_from(const State& s) {
  return {1.0, 1.0, 0.2, 0.01, s.q[0], s.q[1], s.q[2], s.p[0], s.p[1], s.p[2], s.force[0], s.force[1], s.force[2]};
}

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
BENCHMARK(Step_Sleigh);
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
