// The Chaplygin sleigh in centre-of-mass coordinates (x, y, theta): M = diag(m, m, I), the
// blade at C - a e(theta) cannot slide sideways: sin(theta) xdot - cos(theta) ydot + a thetadot = 0.
#include <nonholo/model_builder.hpp>
#include <nonholo/scenarios/scene.hpp>

#include <cmath>

namespace nonholo::scenarios {

SceneInfo sleigh_scene() {
  SceneInfo info;
  info.name = "sleigh";
  info.description = "Chaplygin sleigh, centre-of-mass coordinates, blade a behind the centre";
  info.parameters = {
      {"m", 1.0, "mass"},
      {"I", 1.0, "moment of inertia about the centre of mass"},
      {"a", 0.2, "distance from the centre of mass back to the blade"},
      {"v0", 1.0, "initial forward speed"},
      {"omega0", 1.0, "initial turn rate"},
      {"x0", 0.0, "initial x of the centre of mass"},
      {"y0", 0.0, "initial y of the centre of mass"},
      {"theta0", 0.0, "initial heading"},
  };
  info.default_dt = 0.01;
  info.default_t_end = 10.0;
  info.build = [](const Parameters& p) {
    const double a = p["a"], v0 = p["v0"], w0 = p["omega0"], th = p["theta0"];
    ModelBuilder b;
    b.add_planar_body({"x", "y", "theta"}, p.positive("m"), p.positive("I"));
    b.add_knife_edge({0, a});  // a local element: the step streams it without callbacks
    // Centre velocity (v + i a omega) e^{i theta}: already in D.
    const Eigen::Vector3d qdot(v0 * std::cos(th) - a * w0 * std::sin(th),
                               v0 * std::sin(th) + a * w0 * std::cos(th), w0);
    return SceneSetup{b.build(), 0.0, Eigen::Vector3d(p["x0"], p["y0"], th), qdot};
  };
  return info;
}

}  // namespace nonholo::scenarios
