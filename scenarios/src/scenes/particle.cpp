// The nonholonomic particle of the paper's section 6: R^3, M = I, one row zdot - y xdot = 0.
#include <nonholo/model_builder.hpp>
#include <nonholo/scenarios/scene.hpp>

namespace nonholo::scenarios {

SceneInfo particle_scene() {
  SceneInfo info;
  info.name = "particle";
  info.description = "nonholonomic particle in R^3, M = I, constraint zdot - y xdot = 0";
  info.parameters = {
      {"x0", 0.0, "initial x"},
      {"y0", 0.0, "initial y"},
      {"z0", 0.0, "initial z"},
      {"vx0", 1.0, "initial xdot (guess, projected onto D)"},
      {"vy0", 1.0, "initial ydot (guess, projected onto D)"},
      {"vz0", 0.0, "initial zdot (guess, projected onto D)"},
  };
  info.default_dt = 0.01;
  info.default_t_end = 10.0;
  info.build = [](const Parameters& p) {
    ModelBuilder b;
    b.add_body({"x", "y", "z"}, Eigen::Matrix3d::Identity());
    b.add_one_form({0, 2});  // -y xdot + zdot
    b.one_form_values([](ConstVecRef q, VecRef mu) {
      mu[0] = -q[1];
      mu[1] = 1.0;
    });
    b.one_form_bias([](ConstVecRef, ConstVecRef v, VecRef bias) { bias[0] = -v[1] * v[0]; });
    SceneSetup s{b.build(), 0.0, Eigen::Vector3d(p["x0"], p["y0"], p["z0"]),
                 Eigen::Vector3d(p["vx0"], p["vy0"], p["vz0"])};
    return s;
  };
  return info;
}

}  // namespace nonholo::scenarios
