// The Chaplygin sleigh integrated twice from one consistent start: by the reflection
// (order 2) and by ARKODE's Verner 6(5) pair at a tight tolerance; they agree to O(h^2).
#include <nonholo/nonholo.hpp>
#include <nonholo/reference/integrators.hpp>

#include <cmath>
#include <cstdio>

int main() {
  using namespace nonholo;
  ModelBuilder builder;
  builder.add_planar_body({"x", "y", "theta"}, 2.0, 0.5);
  builder.add_one_form({0, 1, 2});  // blade 0.3 behind the centre
  builder.one_form_values([](ConstVecRef q, VecRef mu) {
    mu << std::sin(q[2]), -std::cos(q[2]), 0.3;
  });
  const Model model = builder.build();

  Workspace ws(model);
  State state = start_from_velocity(model, ws, 0.0, Vector::Zero(3), Vector::Ones(3));
  Vector v0(3);  // the projected velocity M^-1 p~_0, where ARKODE starts too
  model.inverse_mass().multiply(state.p.data(), v0.data());

  reference::Options options;
  options.tol = 1e-11;
  reference::Integrator arkode(model, reference::Method::ArkodeVerner, options, 0.0, state.q, v0);
  const RattleOptions rattle{0.01};
  for (int k = 0; k < 1000; ++k)
    if (step(model, ws, state, rattle) != Status::Ok) {
      std::fprintf(stderr, "step failed: %s\n", ws.message());
      return 1;
    }
  if (arkode.advance_to(state.t) != Status::Ok) {
    std::fprintf(stderr, "ARKODE failed: %s\n", arkode.message().c_str());
    return 1;
  }
  const double difference = (state.q - arkode.q()).lpNorm<Eigen::Infinity>();
  std::printf("t=%g reflection-arkode=%.3g arkode_steps=%ld\n", state.t, difference,
              arkode.steps());
  return difference < 1e-3 ? 0 : 1;
}
