// A thin uniform disk rolling without slipping on the horizontal plane under gravity
// (nonholo/elements.hpp RollingDisk; the benchmark of Hante's RATTLie_nonhol and rolling_disk):
// free in 3-D, three contact rows, the vertical one the holonomic height of the centre,
// enforced at position level by default. Gravity is a constant force, so the discrete
// work-energy identity holds to round-off (energy_balance_err_max).
#include <nonholo/model_builder.hpp>
#include <nonholo/scenarios/scene.hpp>

#include "scenes/rigid/rigid_parameters.hpp"

#include <Eigen/Geometry>

#include <cmath>

namespace nonholo::scenarios {

SceneInfo rolling_disk_scene() {
  SceneInfo info;
  info.name = "rolling_disk";
  info.description = "thin disk rolling without slipping on a plane under gravity";
  info.parameters = join({{{"m", 15.0, "mass (inertia m r^2/4 about a diameter, m r^2/2 about the axis)"},
                           {"r", 1.0, "radius"},
                           {"g", 9.81, "gravity"},
                           {"qw", 0.0, "initial orientation quaternion, w (default: upright, axis along y)"},
                           {"qx", 0.0, "initial orientation quaternion, x"},
                           {"qy", M_SQRT1_2, "initial orientation quaternion, y"},
                           {"qz", M_SQRT1_2, "initial orientation quaternion, z"},
                           {"x0", 0.0, "initial x of the centre"},
                           {"y0", 0.0, "initial y of the centre"}},
                          angular_velocity_specs(0.0, 15.0, 5.0,
                                                 "the disk's axis is body z; the centre's velocity follows "
                                                 "from rolling")});
  info.default_dt = 1.0 / 512.0;  // h |Omega| = 0.03: the period-2 mode's seed (h |Omega|)^3 stays below 1e-4
  info.default_t_end = 2.0;
  info.build = [](const Parameters& p) {
    const double m = p.positive("m"), r = p.positive("r");
    RigidBody body;
    body.mass = m;
    body.inertia = Eigen::Vector3d(m * r * r / 4.0, m * r * r / 4.0, m * r * r / 2.0).asDiagonal();
    body.translation = 3;
    ModelBuilder b;
    b.add_rigid_body(body);
    b.add_rolling_disk({0, r}, "rolling disk");
    b.add_gravity(p["g"]);
    Eigen::Vector4d orientation(p["qw"], p["qx"], p["qy"], p["qz"]);
    orientation /= orientation.norm();  // q0 keeps the given one: the start refuses a norm off 1 and normalises
    const Eigen::Matrix3d rot = quaternion_matrix(orientation);
    // The contact point below the centre: u = -(e3 - n_z n)/|...|, the centre at height r |...|.
    const Eigen::Vector3d n = rot.col(2), w = Eigen::Vector3d::UnitZ() - n.z() * n, u = -w / w.norm();
    const Eigen::Vector3d omega = angular_velocity_of(p);
    const Eigen::Vector3d xdot = -(rot * omega).cross(r * u);
    Vector q0(7), v0(6);
    q0 << Eigen::Vector4d(p["qw"], p["qx"], p["qy"], p["qz"]), p["x0"], p["y0"], r * w.norm();
    v0 << omega, xdot;
    return SceneSetup{b.build(), 0.0, q0, v0};
  };
  return info;
}

}  // namespace nonholo::scenarios
