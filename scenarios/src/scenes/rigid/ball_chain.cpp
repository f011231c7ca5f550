// A chain of rolling balls (Chaplygin balls) whose centres are joined by massless rods of
// length l (holonomic, |x_i - x_{i+1}| = l): rows ball by ball (rolling of i, then the rod from
// i to i+1), so C is banded. Its horizontal symmetries: each ball's spin about the vertical
// through its centre, and the whole chain rolling along x and along y (N + 2 momentum maps,
// declared as generators). With homogeneous balls (I = J Id, the default) the rods make D
// non-invariant: the non-trivial case of the paper's Theorem 1 (docs/guide/rigid-bodies.md).
#include <nonholo/model_builder.hpp>
#include <nonholo/scenarios/scene.hpp>

#include "scenes/rigid/ball_symmetries.hpp"
#include "scenes/rigid/rigid_parameters.hpp"

#include <Eigen/Geometry>

namespace nonholo::scenarios {

SceneInfo ball_chain_scene() {
  SceneInfo info;
  info.name = "ball_chain";
  info.description = "rolling balls whose centres are joined by rods in a chain";
  info.parameters = {
      {"bodies", 3, "number of balls N (1 to 100000)"},
      {"length", 3.0, "rod length l between neighbouring centres"},
      {"m", 1.0, "mass of each ball"},
      {"r", 1.0, "radius of each ball"},
      {"I1", 0.4, "principal moment of inertia about body x (I1 = I2 = I3 = 0.4: homogeneous balls)"},
      {"I2", 0.4, "principal moment of inertia about body y (set I1=0.3 I3=0.5 for Chaplygin balls)"},
      {"I3", 0.4, "principal moment of inertia about body z"},
      any_inertia_spec(),
      {"symmetries", 1, "1: declare the N + 2 momentum maps (each spin, the rolling along x and y), which the "
                        "restarts then keep exactly (each spin local to its ball: a restart costs about one step); 0: none"},
  };
  info.default_dt = 0.01;
  info.default_t_end = 10.0;
  info.build = [](const Parameters& p) {
    const int n = static_cast<int>(p.whole("bodies", 1, 100000));
    const double r = p.positive("r"), length = p.positive("length");
    RigidBody body;
    body.mass = p.positive("m");
    body.inertia = Eigen::Vector3d(p["I1"], p["I2"], p["I3"]).asDiagonal();
    body.any_inertia = any_inertia_of(p);
    body.translation = 2;
    ModelBuilder b;
    // Per ball: 5 velocities, rows x and y of rolling (4 values each), a rod (4 values).
    b.reserve(n, 5 * n, 3 * n - 1, 12 * n - 4);
    std::vector<BallSlots> slots;
    for (int i = 0; i < n; ++i) {
      b.add_rigid_body(body);
      slots.push_back({6 * i, 5 * i});
    }
    for (int i = 0; i < n; ++i) {
      b.add_rolling_ball({i, r}, "rolling ball " + std::to_string(i));
      if (i + 1 < n) b.add_rod({i, i + 1, length}, "rod " + std::to_string(i) + "-" + std::to_string(i + 1));
    }
    if (p.whole("symmetries", 0, 1) == 1) {
      for (int i = 0; i < n; ++i)
        b.symmetry("spin" + std::to_string(i), vertical_spin(slots[i]), vertical_spin_value(slots[i]), i);
      b.symmetry("roll_x", rolling(slots, r, 0));
      b.symmetry("roll_y", rolling(slots, r, 1));
    }

    // Centres along -x, l apart; ball i turned by .3 + .5 i about (1, i, 1); angular velocity
    // guesses for balls 0-2, a slowly varying one beyond, the centres' velocities from rolling;
    // the start projects it all onto the rods and the rolling.
    const Eigen::Vector3d guesses[3] = {{0.5, 1.0, 0.7}, {-0.2, 0.3, -0.4}, {0.3, -0.6, 0.2}};
    Vector q0(6 * n), v0(5 * n);
    for (int i = 0; i < n; ++i) {
      const Eigen::Vector4d orientation = axis_angle_quaternion(Eigen::Vector3d(1.0, i, 1.0), 0.3 + 0.5 * i);
      // Beyond ball 2 a space-frame angular velocity that varies slowly along the chain: guesses
      // that jump from ball to ball (turned by each ball's own orientation) set neighbouring
      // centres moving apart, and a long chain then holds a tension that grows with N and
      // oscillates faster than the step resolves (a 3000-ball chain ended inaccurate at t = 0.5).
      const double phase = 6.283185307179586 * i / n;
      const Eigen::Vector3d omega =
          i <= 2 ? guesses[i % 3]
                 : Eigen::Vector3d(quaternion_matrix(orientation).transpose() *
                                   Eigen::Vector3d(0.15, 0.3 + 0.1 * std::sin(phase), 0.2 * std::cos(phase)));
      const Eigen::Vector3d xdot = r * (quaternion_matrix(orientation) * omega).cross(Eigen::Vector3d::UnitZ());
      q0.segment<6>(6 * i) << orientation, -i * length, 0.0;
      v0.segment<5>(5 * i) << omega, xdot.head<2>();
    }
    return SceneSetup{std::move(b).build(), 0.0, q0, v0};
  };
  return info;
}

}  // namespace nonholo::scenarios
