// wheeled_train (docs/design.md section 5): a generated sleigh chain whose lead body is driven.
// Per-body m, I, a, d, f are drawn uniformly from [(1 - spread) x, (1 + spread) x] around
// the nominal x, from a seeded splitmix64 stream (the same on every platform). The lead
// gets a force along its heading F(t) = N (force + force_amp sin(force_omega t)) and a
// steering torque tau(t) = N steer sin(steer_omega t + steer_phase): both scale with the
// number of bodies N, so the train's motion does not depend much on its length.
#include <nonholo/scenarios/chain.hpp>

#include <cmath>
#include <cstdint>

#include "scenes/random.hpp"

namespace nonholo::scenarios {

SceneInfo wheeled_train_scene() {
  SceneInfo info;
  info.name = "wheeled_train";
  info.description = "generated N-body wheeled train: seeded per-body parameters, driven lead body";
  info.parameters = {
      {"bodies", 1000, "number of bodies N (1 to 10^7)"},
      {"seed", 1, "seed of the per-body parameters (whole number >= 0)"},
      {"spread", 0.25, "per-body parameters are uniform in [(1-spread) x, (1+spread) x], spread in [0, 0.9]"},
      {"m", 1.0, "nominal mass"},
      {"I", 1.0, "nominal moment of inertia about the centre"},
      {"a", 0.2, "nominal distance from the centre back to the blade"},
      {"d", 0.5, "nominal distance from the centre back to the rear hitch"},
      {"f", 0.5, "nominal distance from the centre forward to the front hitch"},
      {"k", 0.0, "torsional spring between neighbours, V = k/2 sum (theta_i - theta_{i+1})^2"},
      {"force", 0.2, "lead force along its heading, per body: F(t) = N (force + force_amp sin(force_omega t))"},
      {"force_amp", 0.0, "amplitude of the lead force's oscillation, per body"},
      {"force_omega", 1.0, "angular frequency of the lead force's oscillation"},
      {"steer", 0.005, "steering torque on the lead, per body: tau(t) = N steer sin(steer_omega t + steer_phase)"},
      {"steer_omega", 0.5, "angular frequency of the steering torque"},
      {"steer_phase", 0.0, "phase of the steering torque"},
      {"v0", 1.0, "initial forward speed of the lead (guess, projected onto D)"},
      {"omega0", 0.5, "initial turn rate of the lead (guess, projected onto D)"},
  };
  info.default_dt = 0.01;
  info.default_t_end = 20.0;
  info.build = [](const Parameters& p) {
    const long n = p.whole("bodies", 1, kMaxChainBodies);
    const double spread = p.within("spread", 0.0, 0.9);
    const ChainBody nominal{p.positive("m"), p.positive("I"), p["a"], p.positive("d"), p.positive("f")};
    Random random(static_cast<std::uint64_t>(p.whole("seed", 0, 1L << 52)));
    auto draw = [&](double x) { return x * (1.0 + spread * (2.0 * random.uniform() - 1.0)); };
    ChainSpec spec;
    spec.bodies.resize(static_cast<std::size_t>(n));
    for (auto& b : spec.bodies) b = {draw(nominal.m), draw(nominal.I), draw(nominal.a), draw(nominal.d), draw(nominal.f)};
    spec.k = p.positive("k", true);
    spec.v0 = p["v0"];
    spec.omega0 = p["omega0"];
    const double scale = static_cast<double>(n);
    const double force = p["force"], force_amp = p["force_amp"], force_omega = p["force_omega"];
    const double steer = p["steer"], steer_omega = p["steer_omega"], steer_phase = p["steer_phase"];
    spec.lead_force = [=](double t) { return scale * (force + force_amp * std::sin(force_omega * t)); };
    spec.lead_torque = [=](double t) { return scale * steer * std::sin(steer_omega * t + steer_phase); };
    return build_chain(spec);
  };
  return info;
}

}  // namespace nonholo::scenarios
