// The paper's Chaplygin sleigh (section 6) in contact-point coordinates (x, y, theta): the
// centre of mass lies a ahead of the blade, so the metric depends on theta,
//   M(theta) = [[m, 0, -a m sin], [0, m, a m cos], [-a m sin, a m cos, I + m a^2]],
// and the blade row is [sin theta, -cos theta, 0]. Integrated by the implicit general form
// with the midpoint discrete Lagrangian (theta replaced by its midpoint). Same parameters and
// physical start as `sleigh`: centre at (x0, y0), heading theta0, speed v0, turn rate omega0,
// so the contact point starts at (x0 - a cos theta0, y0 - a sin theta0).
#include <nonholo/model_builder.hpp>
#include <nonholo/scenarios/scene.hpp>

#include <cmath>

namespace nonholo::scenarios {

SceneInfo sleigh_contact_scene() {
  SceneInfo info = sleigh_scene();
  info.name = "sleigh_contact";
  info.description = "Chaplygin sleigh in contact-point coordinates (theta-dependent metric, implicit method)";
  info.build = [](const Parameters& p) {
    const double m = p.positive("m"), inertia = p.positive("I"), a = p["a"];
    const double v0 = p["v0"], w0 = p["omega0"], th = p["theta0"];
    auto metric = [m, inertia, a](double theta, MatRef out) {
      const double s = std::sin(theta), c = std::cos(theta);
      out << m, 0.0, -a * m * s, 0.0, m, a * m * c, -a * m * s, a * m * c, inertia + m * a * a;
    };
    ModelBuilder b;
    Eigen::Matrix3d m0;
    metric(th, m0);
    b.add_body({"x", "y", "theta"}, m0);
    b.configuration_metric([metric](ConstVecRef q, MatRef out) { metric(q[2], out); },
                           [m, a](ConstVecRef q, int i, MatRef out) {
                             out.setZero();
                             if (i != 2) return;
                             const double s = std::sin(q[2]), c = std::cos(q[2]);
                             out(0, 2) = out(2, 0) = -a * m * c;
                             out(1, 2) = out(2, 1) = -a * m * s;
                           });
    b.add_one_form({0, 1, 2});
    b.one_form_values([](ConstVecRef q, VecRef mu) {
      mu[0] = std::sin(q[2]);
      mu[1] = -std::cos(q[2]);
      mu[2] = 0.0;
    });
    b.one_form_bias([](ConstVecRef q, ConstVecRef v, VecRef bias) {
      bias[0] = v[2] * (std::cos(q[2]) * v[0] + std::sin(q[2]) * v[1]);
    });
    // The blade point moves along the heading at the centre's forward speed v0.
    const Eigen::Vector3d q0(p["x0"] - a * std::cos(th), p["y0"] - a * std::sin(th), th);
    const Eigen::Vector3d qdot(v0 * std::cos(th), v0 * std::sin(th), w0);
    return SceneSetup{b.build(), 0.0, q0, qdot};
  };
  return info;
}

}  // namespace nonholo::scenarios
