// A knife edge on a planar body in a harmonic well, built with the public API only:
// model, workspace, consistent start, steps, diagnostics.
#include <nonholo/nonholo.hpp>

#include <cmath>
#include <cstdio>

int main() {
  using namespace nonholo;
  ModelBuilder builder;
  builder.add_planar_body({"x", "y", "theta"}, 2.0, 0.5);
  builder.add_one_form({0, 1, 2});  // blade 0.3 behind the centre: sin th xd - cos th yd + 0.3 thd = 0
  builder.one_form_values([](ConstVecRef q, VecRef mu) {
    mu << std::sin(q[2]), -std::cos(q[2]), 0.3;
  });
  builder.potential([](ConstVecRef q) { return 0.5 * (q[0] * q[0] + q[1] * q[1]); },
                    [](ConstVecRef q, VecRef g) { g << q[0], q[1], 0.0; });
  const Model model = builder.build();

  Workspace ws(model);
  State state = start_from_velocity(model, ws, 0.0, Eigen::Vector3d(1.0, 0.0, 0.0),
                                    Eigen::Vector3d(0.0, 1.0, 0.5));
  const RattleOptions options{0.01};
  const double e0 = diagnose(model, ws, state, options.h).energy;
  double worst = 0.0;
  for (int k = 0; k < 1000; ++k) {
    if (const Status s = step(model, ws, state, options); s != Status::Ok) {
      std::fprintf(stderr, "step failed: %s: %s\n", to_string(s), ws.message());
      return 1;
    }
    const Diagnostics d = diagnose(model, ws, state, options.h);
    worst = std::max(worst, std::abs(d.energy - e0) / e0);
  }
  std::printf("t=%g x=%.6f y=%.6f theta=%.6f energy_rel_err_max=%.3g backend=%s\n", state.t,
              state.q[0], state.q[1], state.q[2], worst, ws.backend_name());
  return worst < 1e-3 ? 0 : 1;
}
