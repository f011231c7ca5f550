#pragma once
// Parameters the 3-D scenes share: an inertia tensor entry by entry, an initial orientation as
// a rotation about an axis, an initial angular velocity.
#include <nonholo/rigid_body.hpp>
#include <nonholo/scenarios/parameters.hpp>

#include <Eigen/Core>

#include <string>
#include <vector>

namespace nonholo::scenarios {

// I11, I22, I33, I12, I13, I23 (the inertia in the body frame; its SPD check is the builder's).
std::vector<ParameterSpec> inertia_specs(double i11, double i22, double i33, double i12 = 0.0, double i13 = 0.0,
                                         double i23 = 0.0, double any_inertia = 0.0, const char* why = "");
Eigen::Matrix3d inertia_of(const Parameters& p);
// any_inertia (0 or 1): RigidBody::any_inertia, principal moments that break the triangle
// inequality accepted on purpose. inertia_specs includes it with the default 0.
ParameterSpec any_inertia_spec(double value = 0.0, const char* why = "");
bool any_inertia_of(const Parameters& p);

// rx, ry, rz, angle: the initial orientation, the rotation by `angle` about (rx, ry, rz).
std::vector<ParameterSpec> orientation_specs(double rx, double ry, double rz, double angle);
Eigen::Vector4d orientation_of(const Parameters& p);

// Omega1, Omega2, Omega3: the initial angular velocity in the body frame (`what` says whether it
// is exact or a guess projected onto the constraints).
std::vector<ParameterSpec> angular_velocity_specs(double w1, double w2, double w3, const std::string& what);
Eigen::Vector3d angular_velocity_of(const Parameters& p);

// Concatenates parameter lists.
std::vector<ParameterSpec> join(std::vector<std::vector<ParameterSpec>> lists);

}  // namespace nonholo::scenarios
