// The Suslov problem: a rigid body turning about a fixed point whose angular velocity has no
// component along an axis a fixed in the body, <Omega, a> = 0 (a left-invariant distribution;
// nonholo/elements.hpp BodyAxisConstraint). With a = e3 and I12 = 0 its angular velocity has a
// closed form (exact_solutions.hpp, SuslovSolution): it tends to a steady rotation at the rate
// kappa at which the flow contracts, which makes the period-2 mode grow (docs/guide/rigid-bodies.md).
#include <nonholo/model_builder.hpp>
#include <nonholo/scenarios/scene.hpp>

#include "scenes/rigid/rigid_parameters.hpp"

namespace nonholo::scenarios {

SceneInfo suslov_scene() {
  SceneInfo info;
  info.name = "suslov";
  info.description = "Suslov top: a rigid body about a fixed point, no angular velocity along a body axis a";
  // The classic test inertia of rounds 1-3 (the closed form, kappa, the mode's bursts): its
  // principal moments 0.869, 1.830, 3.301 break the triangle inequality, so the scene opts in.
  info.parameters = join({inertia_specs(1.0, 2.0, 3.0, 0.0, 0.5, 0.5, 1.0,
                                        "; 1 by default here: the default inertia's moments 0.869, 1.830, 3.301 "
                                        "break it (the test case of docs/design.md); set 0 to have yours checked"),
                          {{"a1", 0.0, "constrained body axis a, x"},
                           {"a2", 0.0, "constrained body axis a, y"},
                           {"a3", 1.0, "constrained body axis a, z"}},
                          orientation_specs(0.0, 0.0, 1.0, 0.0),
                          angular_velocity_specs(1.0, 0.6, 0.0, "projected onto <Omega, a> = 0")});
  info.default_dt = 0.01;
  info.default_t_end = 10.0;
  info.build = [](const Parameters& p) {
    ModelBuilder b;
    RigidBody body;
    body.inertia = inertia_of(p);
    body.any_inertia = any_inertia_of(p);
    body.translation = 0;
    b.add_rigid_body(body);
    b.add_body_axis_constraint({0, Eigen::Vector3d(p["a1"], p["a2"], p["a3"])}, "body axis a");
    return SceneSetup{b.build(), 0.0, orientation_of(p), angular_velocity_of(p)};
  };
  return info;
}

}  // namespace nonholo::scenarios
