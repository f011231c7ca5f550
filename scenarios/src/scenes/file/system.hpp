#pragma once
// A scene file as read (read_system.cpp) before its model is built (build_system.cpp): the
// bodies, constraints, couplings and forces of the file with their places in it, for messages.
// The format is <nonholo/scenarios/scene_file.hpp>'s.
#include <nonholo/rigid_body.hpp>
#include <nonholo/scenarios/scene.hpp>

#include <Eigen/Core>

#include <nlohmann/json.hpp>

#include <cmath>
#include <cstddef>
#include <string>
#include <vector>

namespace nonholo::scenarios::scene_file {

// A body of the file: planar (x, y, theta) or a 3-D rigid body (nonholo/rigid_body.hpp).
struct Body {
  bool rigid = false;
  // planar
  double mass = 1.0, inertia = 1.0, x = 0.0, y = 0.0, heading = 0.0, vx = 0.0, vy = 0.0, turn_rate = 0.0;
  // rigid
  RigidBody shape;                                              // mass, inertia, translation (name unused)
  Eigen::Vector4d orientation = Eigen::Vector4d(1.0, 0.0, 0.0, 0.0);  // unit quaternion (w, x, y, z)
  Eigen::Vector3d angular_velocity = Eigen::Vector3d::Zero();   // body frame
  std::vector<double> position, velocity;                       // d entries each
  // Its centre, when it has one that moves (planar: x, y; rigid: d = 2 or 3 entries).
  std::vector<double> centre() const {
    if (!rigid) return {x, y};
    return shape.translation >= 2 ? position : std::vector<double>();
  }
};
// A constraint of the file: one element of elements.hpp (a hitch adds two rows, a rolling
// ball two or three, a rolling disk three).
struct Constraint {
  enum Kind { kKnife, kHitch, kBodyAxis, kSpaceAxis, kBall, kDisk, kRod } kind;
  int a = 0, b = 0;          // its body; its two bodies for a hitch (rear, front) and a rod
  double p = 0.0, p2 = 0.0;  // offset; rear, front; radius; length
  Eigen::Vector3d axis = Eigen::Vector3d::UnitZ();
  std::size_t index = 0;     // in "constraints", for messages
  std::string label;         // "knife_edge on body 2", "rod of bodies 0 and 1"
  bool joins_two() const { return kind == kHitch || kind == kRod; }
};
struct Spring {
  int a, b;
  double stiffness, rest;
  std::size_t index;  // in "couplings"
};
// A thrust or torque on a planar body, or a body torque or force on a rigid body:
// value + amplitude sin(omega t + phase), per component for the latter; or gravity (g in
// value[0]).
struct Drive {
  enum Kind { kThrust, kTorque, kBodyTorque, kBodyForce, kGravity } kind;
  int body;
  Eigen::Vector3d value, amplitude;  // a thrust's or torque's in the first entry
  double omega, phase;
  std::size_t index;  // in "forces"
  double at(double t) const { return value[0] + amplitude[0] * std::sin(omega * t + phase); }
  Eigen::Vector3d vector_at(double t) const { return value + amplitude * std::sin(omega * t + phase); }
};
struct System {
  std::vector<Body> bodies;
  std::vector<Constraint> constraints;
  std::vector<Spring> springs;
  std::vector<Drive> drives;  // in the file's order
  double dt = 0.01, t_end = 10.0;
  std::string file;  // for messages
};

// The file's text as a System: every value checked, the holonomic constraints closed at the
// start. Throws std::invalid_argument naming the file and the path of the value.
System read_system(const std::string& text, const std::string& path);
// read_system's phase for the file's "bodies" (read_bodies.cpp).
class Reader;
void read_bodies(const Reader& r, const nlohmann::json& root, System& s);
// The model of the system, its elements' rows body by body, and its initial state. Throws
// std::invalid_argument with the builder's message prefixed by the element's path.
SceneSetup build_system(const System& s);

}  // namespace nonholo::scenarios::scene_file
