// A train of five hitched sleighs of different sizes from nonholo/scenarios/chain.hpp,
// integrated to t = 10 step by step (the hitches stay closed and the constraints hold), then
// run as the command line runs a scene (run_model: every check, the summary line).
#include <nonholo/nonholo.hpp>
#include <nonholo/scenarios/chain.hpp>
#include <nonholo/scenarios/run.hpp>

#include <cstdio>

int main() {
  using namespace nonholo;
  scenarios::ChainSpec spec;
  for (int i = 0; i < 5; ++i) spec.bodies.push_back({1.0 + 0.1 * i, 0.5, 0.2, 0.4, 0.4});
  const scenarios::SceneSetup scene = scenarios::build_chain(spec);

  Workspace ws(scene.model);
  State state = start_from_velocity(scene.model, ws, scene.t0, scene.q0, scene.v0);
  const RattleOptions options{0.01};
  for (int k = 0; k < 1000; ++k)
    if (step(scene.model, ws, state, options) != Status::Ok) {
      std::fprintf(stderr, "step failed: %s\n", ws.message());
      return 1;
    }
  const Diagnostics d = diagnose(scene.model, ws, state, options.h);
  std::printf("t=%g bodies=%zu gap=%.3g residual=%.3g backend=%s\n", state.t, spec.bodies.size(),
              d.gap, d.residual, ws.backend_name());

  scenarios::RunConfig config;  // the options of `nonholo run`
  config.scene = "train";       // the model's name in the summary
  config.dt = 0.01;
  config.t_end = 10.0;
  const scenarios::RunSummary run = scenarios::run_model(scene.model, {scene.t0, scene.q0, scene.v0, {}}, config);
  std::printf("%s\n", run.line().c_str());
  return d.gap < 1e-9 && d.residual < 1e-12 && run.status == Status::Ok ? 0 : 1;
}
