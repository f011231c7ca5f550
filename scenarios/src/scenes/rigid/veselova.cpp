// The Veselova problem: a rigid body turning about a fixed point whose angular velocity has no
// component along the vertical, <Omega, gamma> = 0 with gamma = R^T e3 (a right-invariant
// distribution; nonholo/elements.hpp SpaceAxisConstraint). It has an invariant measure, and
// besides the energy the integral F = |I Omega|^2 - (I Omega . gamma)^2, which the scheme keeps
// by its structure (docs/guide/rigid-bodies.md).
#include <nonholo/model_builder.hpp>
#include <nonholo/scenarios/scene.hpp>

#include "scenes/rigid/rigid_parameters.hpp"

namespace nonholo::scenarios {

SceneInfo veselova_scene() {
  SceneInfo info;
  info.name = "veselova";
  info.description = "Veselova top: a rigid body about a fixed point, no spin about the vertical";
  info.parameters = join({inertia_specs(1.0, 2.0, 3.0), orientation_specs(1.0, 1.0, 0.0, 0.8),
                          angular_velocity_specs(0.5, 1.0, -0.3, "guess, projected onto <Omega, gamma> = 0")});
  info.default_dt = 0.01;
  info.default_t_end = 10.0;
  info.build = [](const Parameters& p) {
    ModelBuilder b;
    RigidBody body;
    body.inertia = inertia_of(p);
    body.any_inertia = any_inertia_of(p);
    b.add_rigid_body(body);
    b.add_space_axis_constraint({0, Eigen::Vector3d::UnitZ()}, "no spin about the vertical");
    return SceneSetup{b.build(), 0.0, orientation_of(p), angular_velocity_of(p)};
  };
  return info;
}

}  // namespace nonholo::scenarios
