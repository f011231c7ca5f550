// A scene file's text as a System (system.hpp), in phases: the document, the top level, the
// bodies (read_bodies.cpp), constraints, couplings and forces, then the check that the
// holonomic constraints are closed at the start.
#include <nonholo/rigid_body.hpp>

#include <algorithm>
#include <sstream>
#include <string>
#include <tuple>

#include "scenes/file/document.hpp"
#include "scenes/file/reader.hpp"
#include "scenes/file/system.hpp"

namespace nonholo::scenarios::scene_file {
namespace {

// dt, t_end and the keys of the top level.
System read_top_level(const Reader& r, const json& root, const std::string& path) {
  r.keys(root, "(top level)", {"dt", "t_end", "bodies", "constraints", "couplings", "forces", "description"});
  if (root.contains("description") && !root.at("description").is_string())
    r.fail("description", std::string("expected a string, got ") + root.at("description").type_name());
  System s;
  s.file = path;
  const double dt = 0.01, t_end = 10.0;
  s.dt = r.number(root, "(top level)", "dt", &dt);
  s.t_end = r.number(root, "(top level)", "t_end", &t_end);
  if (!(s.dt > 0.0)) r.fail("dt", "must be positive");
  if (!(s.t_end >= 0.0)) r.fail("t_end", "must not be negative");
  return s;
}

// An optional array of the top level (empty when absent).
json list(const Reader& r, const json& root, const char* key) {
  if (!root.contains(key)) return json::array();
  if (!root.at(key).is_array()) r.fail(key, std::string("expected an array, got ") + root.at(key).type_name());
  return root.at(key);
}

int body_of(const Reader& r, const json& c, const std::string& where, int n) {
  if (!c.contains("body")) r.fail(where + ".body", "missing (a body index is required)");
  return r.body(c.at("body"), where, "body", n);
}

void read_constraints(const Reader& r, const json& root, System& s) {
  const int n = static_cast<int>(s.bodies.size());
  const json constraints = list(r, root, "constraints");
  for (std::size_t i = 0; i < constraints.size(); ++i) {
    const std::string where = "constraints[" + std::to_string(i) + "]";
    const json& c = constraints[i];
    const std::string type = r.type(c, where);
    Constraint k{};
    k.index = i;
    if (type == "knife_edge") {
      r.keys(c, where, {"type", "body", "offset"});
      const double zero = 0.0;
      k.kind = Constraint::kKnife;
      k.a = body_of(r, c, where, n);
      k.p = r.number(c, where, "offset", &zero);
    } else if (type == "hitch") {
      r.keys(c, where, {"type", "bodies", "rear", "front"});
      k.kind = Constraint::kHitch;
      std::tie(k.a, k.b) = r.pair(c, where, n);
      k.p = r.number(c, where, "rear");
      k.p2 = r.number(c, where, "front");
    } else if (type == "body_axis" || type == "space_axis") {
      r.keys(c, where, {"type", "body", "axis"});
      k.kind = type == "body_axis" ? Constraint::kBodyAxis : Constraint::kSpaceAxis;
      k.a = body_of(r, c, where, n);
      k.axis = r.vector3(c, where, "axis", type == "body_axis", Eigen::Vector3d::UnitZ());
    } else if (type == "rolling_ball" || type == "rolling_disk") {
      r.keys(c, where, {"type", "body", "radius"});
      k.kind = type == "rolling_ball" ? Constraint::kBall : Constraint::kDisk;
      k.a = body_of(r, c, where, n);
      k.p = r.positive(c, where, "radius");
    } else if (type == "rod") {
      r.keys(c, where, {"type", "bodies", "length"});
      k.kind = Constraint::kRod;
      std::tie(k.a, k.b) = r.pair(c, where, n);
      k.p = r.positive(c, where, "length");
    } else {
      r.fail(where + ".type", "unknown constraint type '" + type +
                                  "' (known: knife_edge, hitch, body_axis, space_axis, rolling_ball, rolling_disk, rod)");
    }
    k.label = type + (k.joins_two() ? " of bodies " + std::to_string(k.a) + " and " + std::to_string(k.b)
                                    : " on body " + std::to_string(k.a));
    s.constraints.push_back(std::move(k));
  }
}

void read_couplings(const Reader& r, const json& root, System& s) {
  const int n = static_cast<int>(s.bodies.size());
  const json couplings = list(r, root, "couplings");
  for (std::size_t i = 0; i < couplings.size(); ++i) {
    const std::string where = "couplings[" + std::to_string(i) + "]";
    const json& c = couplings[i];
    const std::string type = r.type(c, where);
    if (type != "torsional_spring")
      r.fail(where + ".type", "unknown coupling type '" + type + "' (known: torsional_spring)");
    r.keys(c, where, {"type", "bodies", "stiffness", "rest_angle"});
    const auto [a, b] = r.pair(c, where, n);
    const double zero = 0.0;
    s.springs.push_back({a, b, r.positive(c, where, "stiffness"), r.number(c, where, "rest_angle", &zero), i});
  }
}

void read_forces(const Reader& r, const json& root, System& s) {
  const int n = static_cast<int>(s.bodies.size());
  const json forces = list(r, root, "forces");
  std::size_t gravity = forces.size();  // the index of the gravity entry, if any
  for (std::size_t i = 0; i < forces.size(); ++i) {
    const std::string where = "forces[" + std::to_string(i) + "]";
    const json& f = forces[i];
    const std::string type = r.type(f, where);
    const double zero = 0.0;
    if (type == "gravity") {
      r.keys(f, where, {"type", "g"});
      if (gravity < forces.size())
        r.fail(where, "gravity is given twice (first in forces[" + std::to_string(gravity) + "])");
      gravity = i;
      const double g = 9.81;
      Drive d{Drive::kGravity, -1, Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero(), 0.0, 0.0, i};
      d.value[0] = r.number(f, where, "g", &g);
      s.drives.push_back(d);
      continue;
    }
    const bool scalar = type == "thrust" || type == "torque";
    if (!scalar && type != "body_torque" && type != "body_force")
      r.fail(where + ".type",
             "unknown force type '" + type + "' (known: thrust, torque, gravity, body_torque, body_force)");
    r.keys(f, where, {"type", "body", "value", "amplitude", "omega", "phase"});
    Drive d{type == "thrust"        ? Drive::kThrust
            : type == "torque"      ? Drive::kTorque
            : type == "body_torque" ? Drive::kBodyTorque
                                    : Drive::kBodyForce,
            body_of(r, f, where, n), Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero(), 0.0, 0.0, i};
    if (scalar) {
      d.value[0] = r.number(f, where, "value", &zero);
      d.amplitude[0] = r.number(f, where, "amplitude", &zero);
    } else {
      d.value = r.vector3(f, where, "value", false);
      d.amplitude = r.vector3(f, where, "amplitude", false);
    }
    d.omega = r.number(f, where, "omega", &zero);
    d.phase = r.number(f, where, "phase", &zero);
    s.drives.push_back(d);
  }
  if (gravity < forces.size() &&
      std::none_of(s.bodies.begin(), s.bodies.end(), [](const Body& b) { return b.rigid && b.shape.translation == 3; }))
    r.fail("forces[" + std::to_string(gravity) + "]",
           "gravity acts on rigid bodies that move freely in 3-D (\"translation\": 3), and the file has none");
}

// A hitch of two planar bodies closed at the start.
void check_hitch(const Reader& r, const System& s, const Constraint& c, const std::string& where) {
  const Body& a = s.bodies[static_cast<std::size_t>(c.a)];
  const Body& b = s.bodies[static_cast<std::size_t>(c.b)];
  if (a.rigid || b.rigid) return;
  const double gx = a.x - c.p * std::cos(a.heading) - b.x - c.p2 * std::cos(b.heading);
  const double gy = a.y - c.p * std::sin(a.heading) - b.y - c.p2 * std::sin(b.heading);
  const double gap = std::hypot(gx, gy);
  if (!(gap <= 1e-9 * (1.0 + std::abs(a.x) + std::abs(a.y)))) {  // NaN (overflow) is open too
    std::ostringstream os;
    os << "the hitch is open at the start: its two points are " << gap << " apart (place body " << c.b
       << " so that they meet)";
    r.fail(where, os.str());
  }
}

// A rod at its length at the start (centres of the same dimension).
void check_rod(const Reader& r, const System& s, const Constraint& c, const std::string& where) {
  const std::vector<double> ca = s.bodies[static_cast<std::size_t>(c.a)].centre(),
                            cb = s.bodies[static_cast<std::size_t>(c.b)].centre();
  if (ca.empty() || ca.size() != cb.size()) return;
  double scale = 1.0 + c.p;
  for (std::size_t i = 0; i < ca.size(); ++i) scale = std::max({scale, std::abs(ca[i]), std::abs(cb[i])});
  const double dx = ca[0] - cb[0], dy = ca[1] - cb[1];
  const double distance = ca.size() == 3 ? std::hypot(dx, dy, ca[2] - cb[2]) : std::hypot(dx, dy);
  if (!(std::abs(distance - c.p) <= 1e-9 * scale)) {
    std::ostringstream os;
    os << "the rod is not at its length at the start: the centres of bodies " << c.a << " and " << c.b << " are "
       << distance << " apart, the rod is " << c.p << " long (place body " << c.b << " at distance " << c.p
       << " from body " << c.a << ")";
    r.fail(where, os.str());
  }
}

// A rolling ball or disk free in 3-D on the ground at the start.
void check_on_ground(const Reader& r, const System& s, const Constraint& c, const std::string& where) {
  const Body& a = s.bodies[static_cast<std::size_t>(c.a)];
  if (!a.rigid || a.shape.translation != 3) return;
  const double z = a.position[2];
  const std::string set = "set bodies[" + std::to_string(c.a) + "].position[2] to ";
  std::ostringstream os;
  if (c.kind == Constraint::kBall) {
    if (!(std::abs(z - c.p) <= 1e-9 * (1.0 + c.p + std::abs(z)))) {
      os << "the ball is not on the ground at the start: its centre is at height " << z << ", its radius is " << c.p
         << " (" << set << exact(c.p) << ")";
      r.fail(where, os.str());
    }
    return;
  }
  // Its centre is r |w| above the contact point, w = e3 - n_z n, n = R e3 its axis
  // (|w| = sqrt(1 - n_z^2), computed as the element does).
  const Eigen::Vector3d axis = quaternion_matrix(a.orientation).col(2);
  const double tilt = (Eigen::Vector3d::UnitZ() - axis.z() * axis).norm();
  if (!(tilt > 1e-8)) {
    os << "the disk lies flat at the start (its axis R e3 is vertical, sin of its tilt " << tilt
       << "): it has no contact point; tilt it (bodies[" << c.a << "].orientation)";
    r.fail(where, os.str());
  }
  const double height = c.p * tilt;
  if (!(std::abs(z - height) <= 1e-9 * (1.0 + c.p + std::abs(z)))) {
    os << "the disk is not on the ground at the start: its centre is at height " << z << ", and a disk of radius "
       << c.p << " tilted as it is (axis R e3 = (" << axis.x() << ", " << axis.y() << ", " << axis.z()
       << ")) touches the ground with its centre at r sqrt(1 - n_z^2) = " << height << " (" << set
       << exact(height) << ")";
    r.fail(where, os.str());
  }
}

// The holonomic constraints must hold at the start: hitches closed, rods at their length,
// balls and disks on the ground. Elements the builder refuses anyway (a hitch on a rigid body,
// a rod between centres of different dimensions, a disk whose centre cannot rise) are left to
// it.
void check_closed(const Reader& r, const System& s) {
  for (const Constraint& c : s.constraints) {
    const std::string where = "constraints[" + std::to_string(c.index) + "]";
    if (c.kind == Constraint::kHitch) check_hitch(r, s, c, where);
    if (c.kind == Constraint::kRod) check_rod(r, s, c, where);
    if (c.kind == Constraint::kBall || c.kind == Constraint::kDisk) check_on_ground(r, s, c, where);
  }
}

}  // namespace

System read_system(const std::string& text, const std::string& path) {
  const json root = parse_document(text, path);
  const Reader r(path);
  System s = read_top_level(r, root, path);
  read_bodies(r, root, s);
  read_constraints(r, root, s);
  read_couplings(r, root, s);
  read_forces(r, root, s);
  check_closed(r, s);
  return s;
}

}  // namespace nonholo::scenarios::scene_file
