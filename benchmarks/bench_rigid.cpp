// 3-D rigid bodies (docs/guide/rigid-bodies.md): one step of each 3-D scene with the default options,
// and the drift of one body in the same run: a planar body's (q + h M^-1 p) against a rigid
// body's, whose discrete Legendre transform is a 3x3 Newton iteration (Moser-Veselov, MV-F,
// exponential) or a closed form (an isotropic body). And chains of N balls (N = 10^3 ... 10^5,
// the scene's defaults with its N + 2 momentum maps) against the planar chain of the same N in
// both hitch modes, and a restart of the ball chain against its step.
#include <nonholo/model_builder.hpp>
#include <nonholo/rattle.hpp>
#include <nonholo/restart.hpp>
#include <nonholo/scenarios/scene.hpp>
#include <nonholo/start.hpp>

#include <benchmark/benchmark.h>

#include "step/rigid/drift.hpp"  // the drift alone (nonholo_private_headers)

#include <algorithm>
#include <string>
#include <vector>

namespace {

using namespace nonholo;

double minimum(const std::vector<double>& v) { return *std::min_element(v.begin(), v.end()); }

void run_steps(benchmark::State& bench, const std::string& scene) {
  const auto& info = scenarios::find_scene(scene);
  const scenarios::SceneSetup setup = info.build(info.defaults());
  Workspace ws(setup.model);
  State s = start_from_velocity(setup.model, ws, 0.0, setup.q0, setup.v0);
  RattleOptions options;
  options.h = info.default_dt;
  for (auto _ : bench) {
    if (step(setup.model, ws, s, options) != Status::Ok) bench.SkipWithError(ws.message());
    benchmark::DoNotOptimize(s.q.data());
  }
  bench.SetLabel(std::string(ws.backend_name()) + ", Newton iterations up to " + std::to_string(ws.legendre_iterations));
}

void Step_Suslov(benchmark::State& s) { run_steps(s, "suslov"); }
void Step_Veselova(benchmark::State& s) { run_steps(s, "veselova"); }
void Step_ChaplyginBall(benchmark::State& s) { run_steps(s, "chaplygin_ball"); }
void Step_BallChain(benchmark::State& s) { run_steps(s, "ball_chain"); }
void Step_RollingDisk(benchmark::State& s) { run_steps(s, "rolling_disk"); }

// One body's drift through detail::drift, the momentum turned a little each time (the Newton
// iteration starts afresh; 3 iterations at h |Omega| = 0.01 ... 0.02 for a non-isotropic body).
void run_drift(benchmark::State& bench, bool rigid, bool isotropic, RotationLagrangian rotation) {
  ModelBuilder b;
  if (rigid) {
    RigidBody body;
    if (!isotropic) body.inertia << 1, 0, .5, 0, 2, .5, .5, .5, 3;
    body.any_inertia = true;  // the Suslov scene's test inertia
    b.add_rigid_body(body);
  } else {
    b.add_planar_body({"x", "y", "theta"}, 1.0, 1.0);
  }
  const Model model = b.build();
  Vector q = rigid ? Vector(Eigen::Vector4d(1, 0, 0, 0)) : Vector(Eigen::Vector3d(0, 0, 0));
  Vector q_out(q.size()), p(3), v(3), p_out(3);
  p << 1.0, 1.2, 0.6;
  model.inverse_mass().multiply(p.data(), v.data());
  int iterations = 0, most = 0;
  for (auto _ : bench) {
    p[0] += 1e-9;  // a new momentum each time
    if (detail::drift(model, rotation, 0.01, q.data(), p.data(), v.data(), q_out.data(), p_out.data(), iterations) >= 0)
      bench.SkipWithError("no solution");
    most = std::max(most, iterations);
    benchmark::DoNotOptimize(q_out.data());
    benchmark::DoNotOptimize(p_out.data());
  }
  bench.SetLabel("Newton iterations " + std::to_string(most));
}

void Drift_PlanarBody(benchmark::State& s) { run_drift(s, false, false, RotationLagrangian::MoserVeselov); }
void Drift_RigidBody_MoserVeselov(benchmark::State& s) { run_drift(s, true, false, RotationLagrangian::MoserVeselov); }
void Drift_RigidBody_MoserVeselovF(benchmark::State& s) { run_drift(s, true, false, RotationLagrangian::MoserVeselovF); }
void Drift_RigidBody_Exponential(benchmark::State& s) { run_drift(s, true, false, RotationLagrangian::Exponential); }
void Drift_IsotropicBody_MoserVeselov(benchmark::State& s) { run_drift(s, true, true, RotationLagrangian::MoserVeselov); }

// A chain scene of N = range(0) bodies with its defaults, started.
struct ChainRun {
  scenarios::SceneSetup setup;
  Workspace ws;
  State s;
  RattleOptions options;
  ChainRun(benchmark::State& bench, const std::string& scene)
      : setup(build(bench, scene)), ws(setup.model), s(start_from_velocity(setup.model, ws, 0.0, setup.q0, setup.v0)) {
    options.h = scenarios::find_scene(scene).default_dt;
  }
  static scenarios::SceneSetup build(benchmark::State& bench, const std::string& scene) {
    const auto& info = scenarios::find_scene(scene);
    auto p = info.defaults();
    p.assign("bodies=" + std::to_string(bench.range(0)));
    return info.build(p);
  }
};

// One step of the chain, holonomic (range(1) = 0) or one-form hitches (1): the ball chain's rods,
// the planar chain's hitches. Items: bodies (so items/s is body-steps).
void run_chain(benchmark::State& bench, const std::string& scene) {
  ChainRun run(bench, scene);
  run.options.hitch = bench.range(1) ? HitchMode::OneForm : HitchMode::Holonomic;
  for (auto _ : bench) {
    if (step(run.setup.model, run.ws, run.s, run.options) != Status::Ok) bench.SkipWithError(run.ws.message());
    benchmark::DoNotOptimize(run.s.q.data());
  }
  bench.SetItemsProcessed(bench.iterations() * bench.range(0));
}
void Chain_Balls(benchmark::State& s) { run_chain(s, "ball_chain"); }
void Chain_Sleighs(benchmark::State& s) { run_chain(s, "sleigh_chain"); }

// A restart of the ball chain of N = range(0) balls (its N + 2 maps kept) at a state 10 steps in:
// compare with Chain_Balls/N/0 (one step); the goal is under 3 steps at N = 10^5.
void Chain_Balls_Restart(benchmark::State& bench) {
  ChainRun run(bench, "ball_chain");
  for (int k = 0; k < 10; ++k)
    if (step(run.setup.model, run.ws, run.s, run.options) != Status::Ok) bench.SkipWithError(run.ws.message());
  for (auto _ : bench) {
    if (restart(run.setup.model, run.ws, run.s, run.options) != Status::Ok) bench.SkipWithError(run.ws.message());
    benchmark::DoNotOptimize(run.s.lambda.data());
  }
  bench.SetItemsProcessed(bench.iterations() * bench.range(0));
}

}  // namespace

BENCHMARK(Chain_Balls)->ArgsProduct({{1000, 10000, 100000}, {0, 1}})->Unit(benchmark::kMillisecond)->ComputeStatistics("min", minimum);
BENCHMARK(Chain_Sleighs)->ArgsProduct({{1000, 10000, 100000}, {0, 1}})->Unit(benchmark::kMillisecond)->ComputeStatistics("min", minimum);
BENCHMARK(Chain_Balls_Restart)->Arg(1000)->Arg(10000)->Arg(100000)->Unit(benchmark::kMillisecond)->ComputeStatistics("min", minimum);
BENCHMARK(Step_Suslov)->ComputeStatistics("min", minimum);
BENCHMARK(Step_Veselova)->ComputeStatistics("min", minimum);
BENCHMARK(Step_ChaplyginBall)->ComputeStatistics("min", minimum);
BENCHMARK(Step_BallChain)->ComputeStatistics("min", minimum);
BENCHMARK(Step_RollingDisk)->ComputeStatistics("min", minimum);
BENCHMARK(Drift_PlanarBody)->ComputeStatistics("min", minimum);
BENCHMARK(Drift_RigidBody_MoserVeselov)->ComputeStatistics("min", minimum);
BENCHMARK(Drift_RigidBody_MoserVeselovF)->ComputeStatistics("min", minimum);
BENCHMARK(Drift_RigidBody_Exponential)->ComputeStatistics("min", minimum);
BENCHMARK(Drift_IsotropicBody_MoserVeselov)->ComputeStatistics("min", minimum);

BENCHMARK_MAIN();
