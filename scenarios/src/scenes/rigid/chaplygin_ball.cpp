// The Chaplygin ball: a ball with its centre of mass at its geometric centre and any inertia,
// rolling without slipping on the horizontal plane (nonholo/elements.hpp RollingBall). Its
// contact angular momentum R K, K = I Omega + m r^2 gamma x (Omega x gamma), is constant in
// space: its three components are the momentum maps of horizontal symmetries (declared with
// ModelBuilder::symmetry, so that restarts keep them), and they span D: the restarts then keep
// p~ and turn lambda~ onto lambda_s's ray (docs/design.md section 10.3).
#include <nonholo/model_builder.hpp>
#include <nonholo/scenarios/scene.hpp>

#include "scenes/rigid/ball_symmetries.hpp"
#include "scenes/rigid/rigid_parameters.hpp"

#include <Eigen/Geometry>

namespace nonholo::scenarios {

SceneInfo chaplygin_ball_scene() {
  SceneInfo info;
  info.name = "chaplygin_ball";
  info.description = "Chaplygin ball: a ball with any inertia rolling without slipping on a plane";
  info.parameters = join({{{"m", 1.0, "mass"}, {"r", 1.0, "radius"}},
                          inertia_specs(0.3, 0.4, 0.5),
                          orientation_specs(1.0, 2.0, 0.5, 0.7),
                          angular_velocity_specs(1.0, -0.5, 2.0, "exact; the centre's velocity follows from rolling"),
                          {{"x0", 0.0, "initial x of the centre"}, {"y0", 0.0, "initial y of the centre"}}});
  info.default_dt = 0.01;
  info.default_t_end = 10.0;
  info.build = [](const Parameters& p) {
    const double r = p.positive("r");
    ModelBuilder b;
    RigidBody body;
    body.mass = p.positive("m");
    body.inertia = inertia_of(p);
    body.any_inertia = any_inertia_of(p);
    body.translation = 2;
    b.add_rigid_body(body);
    b.add_rolling_ball({0, r}, "rolling ball");
    const BallSlots slots{0, 0};
    b.symmetry("K_x", rolling({slots}, r, 0));
    b.symmetry("K_y", rolling({slots}, r, 1));
    b.symmetry("K_z", vertical_spin(slots), vertical_spin_value(slots), 0);
    const Eigen::Vector4d orientation = orientation_of(p);
    const Eigen::Vector3d omega = angular_velocity_of(p);
    const Eigen::Vector3d xdot = r * (quaternion_matrix(orientation) * omega).cross(Eigen::Vector3d::UnitZ());
    Vector q0(6), v0(5);
    q0 << orientation, p["x0"], p["y0"];
    v0 << omega, xdot.head<2>();
    return SceneSetup{b.build(), 0.0, q0, v0};
  };
  return info;
}

}  // namespace nonholo::scenarios
