// The snakeboard of the paper's section 6: q = (x, y, theta, psi, phi), M = diag(m, m,
// J + 2 J1, J0, 2 J1), wheels that cannot slide sideways (two rows). psi is the rotor's
// absolute angle, phi the axles' angle relative to the board. Optional sinusoidal controls:
// the rider's torque u_psi acts between rotor and board (+u_psi on psi, -u_psi on theta),
// the axle torque u_phi on phi; u(t) = amp sin(omega t + phase).
#include <nonholo/model_builder.hpp>
#include <nonholo/scenarios/scene.hpp>

#include <cmath>

namespace nonholo::scenarios {

SceneInfo snakeboard_scene() {
  SceneInfo info;
  info.name = "snakeboard";
  info.description = "snakeboard (board, rotor, coupled wheel axles), optional sinusoidal controls";
  info.parameters = {
      {"m", 1.0, "total mass"},
      {"J", 0.1, "board moment of inertia about its centre"},
      {"J0", 0.1, "rotor moment of inertia"},
      {"J1", 0.01, "moment of inertia of each wheel axle"},
      {"r", 0.5, "distance from the board centre to the axles"},
      {"x0", 0.0, "initial x"},
      {"y0", 0.0, "initial y"},
      {"theta0", 0.0, "initial board heading"},
      {"psi0", 0.0, "initial rotor angle"},
      {"phi0", 0.3, "initial axle angle (relative to the board)"},
      {"v0", 1.0, "initial forward speed of the board centre (guess, projected onto D)"},
      {"psi_dot0", 0.5, "initial rotor rate"},
      {"phi_dot0", 0.0, "initial axle rate"},
      {"u_psi_amp", 0.0, "amplitude of the rider's torque u_psi"},
      {"u_psi_omega", 1.0, "angular frequency of u_psi"},
      {"u_psi_phase", 0.0, "phase of u_psi"},
      {"u_phi_amp", 0.0, "amplitude of the axle torque u_phi"},
      {"u_phi_omega", 1.0, "angular frequency of u_phi"},
      {"u_phi_phase", 0.0, "phase of u_phi"},
  };
  info.default_dt = 0.01;
  info.default_t_end = 10.0;
  info.build = [](const Parameters& p) {
    const double m = p.positive("m"), J = p.positive("J"), J0 = p.positive("J0"),
                 J1 = p.positive("J1"), r = p["r"];
    ModelBuilder b;
    b.add_body({"x", "y", "theta", "psi", "phi"},
               (Eigen::VectorXd(5) << m, m, J + 2.0 * J1, J0, 2.0 * J1).finished().asDiagonal().toDenseMatrix());
    b.add_one_form({0, 1, 2});  // axle at centre - r e(theta), turned by +phi
    b.add_one_form({0, 1, 2});  // axle at centre + r e(theta), turned by -phi
    b.one_form_values([r](ConstVecRef q, VecRef mu) {
      const double th = q[2], ph = q[4];
      mu[0] = std::sin(th + ph);
      mu[1] = -std::cos(th + ph);
      mu[2] = r * std::cos(ph);
      mu[3] = std::sin(th - ph);
      mu[4] = -std::cos(th - ph);
      mu[5] = -r * std::cos(ph);
    });
    b.one_form_bias([r](ConstVecRef q, ConstVecRef v, VecRef bias) {
      const double th = q[2], ph = q[4], xd = v[0], yd = v[1], thd = v[2], phd = v[4];
      const double spin = r * std::sin(ph) * phd * thd;
      bias[0] = (thd + phd) * (std::cos(th + ph) * xd + std::sin(th + ph) * yd) - spin;
      bias[1] = (thd - phd) * (std::cos(th - ph) * xd + std::sin(th - ph) * yd) + spin;
    });
    const double a_psi = p["u_psi_amp"], w_psi = p["u_psi_omega"], f_psi = p["u_psi_phase"];
    const double a_phi = p["u_phi_amp"], w_phi = p["u_phi_omega"], f_phi = p["u_phi_phase"];
    if (a_psi != 0.0 || a_phi != 0.0)
      b.external_force([=](double t, ConstVecRef, VecRef f) {
        const double u_psi = a_psi * std::sin(w_psi * t + f_psi);
        f << 0.0, 0.0, -u_psi, u_psi, a_phi * std::sin(w_phi * t + f_phi);
      });
    // psi is a horizontal symmetry: without u_psi its momentum J0 psidot is conserved.
    b.momentum_map("rotor", [](ConstVecRef, ConstVecRef mom) { return mom[3]; });

    const double th = p["theta0"], ph = p["phi0"], v0 = p["v0"];
    Eigen::VectorXd q0(5), v(5);
    q0 << p["x0"], p["y0"], th, p["psi0"], ph;
    // Board centre moving at v0 along its heading, turning as the axles dictate.
    v << v0 * std::cos(th), v0 * std::sin(th), r != 0.0 ? -v0 * std::tan(ph) / r : 0.0,
        p["psi_dot0"], p["phi_dot0"];
    return SceneSetup{b.build(), 0.0, q0, v};
  };
  return info;
}

}  // namespace nonholo::scenarios
