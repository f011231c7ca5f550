// The 3-D scenes' shared parameters (rigid_parameters.hpp): inertia entries, the initial orientation as an
// axis and angle, the initial angular velocity, and the join of parameter lists.
#include "scenes/rigid/rigid_parameters.hpp"

#include <stdexcept>

namespace nonholo::scenarios {

std::vector<ParameterSpec> inertia_specs(double i11, double i22, double i33, double i12, double i13, double i23,
                                         double any_inertia, const char* why) {
  return {{"I11", i11, "inertia, body frame (entry 1,1)"},
          {"I22", i22, "inertia, body frame (entry 2,2)"},
          {"I33", i33, "inertia, body frame (entry 3,3)"},
          {"I12", i12, "inertia, body frame (entry 1,2 = 2,1)"},
          {"I13", i13, "inertia, body frame (entry 1,3 = 3,1)"},
          {"I23", i23, "inertia, body frame (entry 2,3 = 3,2)"},
          any_inertia_spec(any_inertia, why)};
}

ParameterSpec any_inertia_spec(double value, const char* why) {
  return {"any_inertia", value,
          std::string("1: accept principal moments that break the triangle inequality (no rigid body has them)") + why};
}

bool any_inertia_of(const Parameters& p) { return p.whole("any_inertia", 0, 1) == 1; }

Eigen::Matrix3d inertia_of(const Parameters& p) {
  Eigen::Matrix3d i;
  i << p["I11"], p["I12"], p["I13"], p["I12"], p["I22"], p["I23"], p["I13"], p["I23"], p["I33"];
  return i;
}

std::vector<ParameterSpec> orientation_specs(double rx, double ry, double rz, double angle) {
  return {{"rx", rx, "initial orientation: rotation axis, x"},
          {"ry", ry, "initial orientation: rotation axis, y"},
          {"rz", rz, "initial orientation: rotation axis, z"},
          {"angle", angle, "initial orientation: rotation angle about (rx, ry, rz)"}};
}

Eigen::Vector4d orientation_of(const Parameters& p) {
  const Eigen::Vector3d axis(p["rx"], p["ry"], p["rz"]);
  if (p["angle"] == 0.0) return {1.0, 0.0, 0.0, 0.0};  // any axis, the zero one too
  if (!(axis.norm() > 0.0))
    throw std::invalid_argument("scene '" + p.scene() + "': the orientation axis (rx, ry, rz) is zero");
  return axis_angle_quaternion(axis, p["angle"]);
}

std::vector<ParameterSpec> angular_velocity_specs(double w1, double w2, double w3, const std::string& what) {
  return {{"Omega1", w1, "initial angular velocity, body frame, x (" + what + ")"},
          {"Omega2", w2, "initial angular velocity, body frame, y (" + what + ")"},
          {"Omega3", w3, "initial angular velocity, body frame, z (" + what + ")"}};
}

Eigen::Vector3d angular_velocity_of(const Parameters& p) { return {p["Omega1"], p["Omega2"], p["Omega3"]}; }

std::vector<ParameterSpec> join(std::vector<std::vector<ParameterSpec>> lists) {
  std::vector<ParameterSpec> out;
  for (auto& l : lists) out.insert(out.end(), l.begin(), l.end());
  return out;
}

}  // namespace nonholo::scenarios
