// build_chain (chain.hpp): a chain of Chaplygin sleighs from knife edges, hitches, springs and thrust, body
// by body, started straight along -x with its hitches closed.
#include <nonholo/scenarios/chain.hpp>

#include <nonholo/model_builder.hpp>

#include <cmath>
#include <sstream>
#include <stdexcept>
#include <string>

namespace nonholo::scenarios {
namespace {

void check_body(const ChainBody& b, std::size_t i) {
  auto positive = [&](const char* what, double v) {
    if (v > 0.0 && std::isfinite(v)) return;
    std::ostringstream os;
    os << "chain body " << i << ": " << what << " = " << v << " must be positive and finite";
    throw std::invalid_argument(os.str());
  };
  positive("m", b.m);
  positive("I", b.I);
  positive("d", b.d);
  positive("f", b.f);
  if (!std::isfinite(b.a)) throw std::invalid_argument("chain body " + std::to_string(i) + ": a is not finite");
}

}  // namespace

SceneSetup build_chain(const ChainSpec& spec) {
  const int n_bodies = static_cast<int>(spec.bodies.size());
  if (n_bodies == 0) throw std::invalid_argument("chain: no bodies");
  for (int i = 0; i < n_bodies; ++i) check_body(spec.bodies[i], static_cast<std::size_t>(i));
  const std::vector<ChainBody>& bodies = spec.bodies;
  const bool hitched = spec.hitched && n_bodies > 1;

  // Local elements (nonholo/elements.hpp), body by body: blade of i, then the hitch from i
  // (rear, d_i) to i+1 (front, f_{i+1}) and the spring between them. Rows and gaps come out
  // in this order, and the step streams the chain in two sweeps (docs/design.md section 7).
  ModelBuilder b;
  const int rows = n_bodies + (hitched ? 2 * (n_bodies - 1) : 0);
  b.reserve(n_bodies, 3 * n_bodies, rows, 3 * n_bodies + (hitched ? 8 * (n_bodies - 1) : 0));
  for (int i = 0; i < n_bodies; ++i) {
    const std::string s = std::to_string(i);
    b.add_planar_body({"x" + s, "y" + s, "theta" + s}, bodies[i].m, bodies[i].I);
  }
  for (int i = 0; i < n_bodies; ++i) {
    b.add_knife_edge({i, bodies[i].a});
    if (hitched && i + 1 < n_bodies) b.add_hitch({i, i + 1, bodies[i].d, bodies[i + 1].f});
    if (spec.k != 0.0 && i + 1 < n_bodies) b.add_torsional_spring({i, i + 1, spec.k});
  }
  if (spec.lead_force || spec.lead_torque) b.add_thrust({0, spec.lead_force, spec.lead_torque});

  SceneSetup setup{std::move(b).build(), 0.0, Vector::Zero(3 * n_bodies), Vector::Zero(3 * n_bodies)};
  // Straight along -x, hitches closed: x_{i+1} = x_i - d_i - f_{i+1}.
  for (int i = 1; i < n_bodies; ++i)
    setup.q0[3 * i] = setup.q0[3 * (i - 1)] - bodies[i - 1].d - bodies[i].f;
  // Body 0 as the single sleigh: centre velocity (v0 + i a omega0) e^{i theta}, theta = 0.
  setup.v0[0] = spec.v0;
  setup.v0[1] = bodies[0].a * spec.omega0;
  setup.v0[2] = spec.omega0;
  return setup;
}

}  // namespace nonholo::scenarios
