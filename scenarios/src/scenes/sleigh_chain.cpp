// sleigh_chain (docs/design.md section 5): N identical Chaplygin sleighs hitched rear to front,
// optional torsional springs between neighbours; hitched=0 leaves only the springs.
#include <nonholo/scenarios/chain.hpp>

namespace nonholo::scenarios {

SceneInfo sleigh_chain_scene() {
  SceneInfo info;
  info.name = "sleigh_chain";
  info.description = "N Chaplygin sleighs hitched in a chain, optional torsional springs";
  info.parameters = {
      {"bodies", 10, "number of sleighs N (1 to 10^7)"},
      {"m", 1.0, "mass of each sleigh"},
      {"I", 1.0, "moment of inertia of each sleigh about its centre"},
      {"a", 0.2, "distance from the centre back to the blade"},
      {"d", 0.5, "distance from the centre back to the rear hitch"},
      {"f", 0.5, "distance from the centre forward to the front hitch"},
      {"k", 0.0, "torsional spring between neighbours, V = k/2 sum (theta_i - theta_{i+1})^2"},
      {"hitched", 1, "1: hitches join the sleighs; 0: only the springs couple them"},
      {"v0", 1.0, "initial forward speed of body 0 (guess, projected onto D)"},
      {"omega0", 0.5, "initial turn rate of body 0 (guess, projected onto D)"},
  };
  info.default_dt = 0.01;
  info.default_t_end = 10.0;
  info.build = [](const Parameters& p) {
    ChainSpec spec;
    const ChainBody body{p.positive("m"), p.positive("I"), p["a"], p.positive("d"), p.positive("f")};
    spec.bodies.assign(static_cast<std::size_t>(p.whole("bodies", 1, kMaxChainBodies)), body);
    spec.hitched = p.whole("hitched", 0, 1) == 1;
    spec.k = p.positive("k", true);
    spec.v0 = p["v0"];
    spec.omega0 = p["omega0"];
    return build_chain(spec);
  };
  return info;
}

}  // namespace nonholo::scenarios
