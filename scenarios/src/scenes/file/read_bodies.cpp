// The "bodies" of a scene file (read_system's first phase): planar bodies (position, heading,
// velocity, turn rate) and 3-D rigid bodies (translation, inertia, orientation, angular
// velocity), each key checked against its kind of body.
#include <nonholo/rigid_body.hpp>

#include <string>

#include "scenes/file/reader.hpp"
#include "scenes/file/system.hpp"

namespace nonholo::scenarios::scene_file {
namespace {

// The keys of each kind of body. A key of the other kind is refused with a message that
// says which kind it belongs to.
const std::set<std::string> kPlanarKeys{"type", "name", "mass", "inertia", "position", "heading", "velocity",
                                        "turn_rate"};
const std::set<std::string> kRigidKeys{"type",        "name",     "mass",             "inertia",  "any_inertia",
                                       "translation", "orientation", "position", "angular_velocity", "velocity"};

void body_keys(const Reader& r, const json& b, const std::string& where, bool rigid) {
  const auto& other = rigid ? kPlanarKeys : kRigidKeys;
  for (auto it = b.begin(); it != b.end(); ++it) {
    const std::string& k = it.key();
    if ((rigid ? kRigidKeys : kPlanarKeys).count(k) || !other.count(k)) continue;
    if (rigid)
      r.fail(where, "key '" + k + "' belongs to planar bodies; this body is rigid (\"type\": \"rigid\")" +
                        (k == "heading"     ? ": give its \"orientation\" instead"
                         : k == "turn_rate" ? ": give its \"angular_velocity\" instead"
                                            : ""));
    r.fail(where, "key '" + k + "' belongs to rigid bodies; this body is planar (add \"type\": \"rigid\" for a 3-D "
                                "rigid body)");
  }
  r.keys(b, where, rigid ? kRigidKeys : kPlanarKeys);
}

// 0, 2 or 3 (default 0).
int read_translation(const Reader& r, const json& b, const std::string& where) {
  if (!b.contains("translation")) return 0;
  const std::string path = where + ".translation";
  const json& t = b.at("translation");
  if (!t.is_number()) r.fail(path, std::string("expected 0, 2 or 3, got ") + t.type_name());
  const double d = t.get<double>();
  if (d == 0.0 || d == 2.0 || d == 3.0) return static_cast<int>(d);
  std::ostringstream os;
  os << "must be 0 (a fixed point), 2 (the centre moves in a horizontal plane) or 3 (free), got " << d;
  r.fail(path, os.str());
}

// 3 principal moments (a diagonal inertia) or a 3x3 array; the builder checks the rest.
Eigen::Matrix3d read_inertia(const Reader& r, const json& b, const std::string& where) {
  const std::string path = where + ".inertia";
  const std::string expected = "expected 3 principal moments [I1, I2, I3] or a 3x3 array [[...], [...], [...]]";
  if (!b.contains("inertia")) r.fail(path, "missing (" + expected.substr(9) + " is required)");
  const json& v = b.at("inertia");
  if (!v.is_array() || v.size() != 3) r.fail(path, expected + ", got " + Reader::count(v));
  Eigen::Matrix3d inertia = Eigen::Matrix3d::Zero();
  if (!v[0].is_array()) {
    for (std::size_t i = 0; i < 3; ++i) {
      const int k = static_cast<int>(i);
      inertia(k, k) = r.entry(v[i], path + "[" + std::to_string(i) + "]");
    }
    return inertia;
  }
  for (std::size_t i = 0; i < 3; ++i) {
    const std::string row = path + "[" + std::to_string(i) + "]";
    if (!v[i].is_array() || v[i].size() != 3)
      r.fail(row, "expected a row of 3 numbers (the inertia is a 3x3 array), got " + Reader::count(v[i]));
    for (std::size_t j = 0; j < 3; ++j)
      inertia(static_cast<int>(i), static_cast<int>(j)) = r.entry(v[i][j], row + "[" + std::to_string(j) + "]");
  }
  return inertia;
}

// A unit quaternion [w, x, y, z] (normalised here) or {"axis": [3], "angle": radians}; default
// the identity.
Eigen::Vector4d read_orientation(const Reader& r, const json& b, const std::string& where) {
  if (!b.contains("orientation")) return {1.0, 0.0, 0.0, 0.0};
  const std::string path = where + ".orientation";
  const json& o = b.at("orientation");
  if (o.is_array()) {
    const auto v = r.numbers(b, where, "orientation", 4, true);
    const Eigen::Vector4d q(v[0], v[1], v[2], v[3]);
    const double norm = q.norm();  // an overflow (inf) is refused too
    if (!(std::abs(norm - 1.0) <= 1e-6)) {
      std::ostringstream os;
      os << "the quaternion [w, x, y, z] has norm " << exact(norm)
         << "; give a unit quaternion (norm within 1e-6 of 1) or {\"axis\": [x, y, z], \"angle\": radians}";
      r.fail(path, os.str());
    }
    return q / norm;
  }
  if (!o.is_object())
    r.fail(path, std::string("expected a unit quaternion [w, x, y, z] or {\"axis\": [x, y, z], \"angle\": radians}, got ") +
                     o.type_name());
  r.keys(o, path, {"axis", "angle"});
  const Eigen::Vector3d axis = r.vector3(o, path, "axis", true);
  const double angle = r.number(o, path, "angle");
  // Scaled to its largest entry first: an axis of tiny or huge entries is still a direction.
  const double scale = axis.cwiseAbs().maxCoeff();
  if (!(scale > 0.0)) r.fail(path + ".axis", "must not be zero");
  try {
    return axis_angle_quaternion(axis / scale, angle);
  } catch (const std::invalid_argument& e) {
    r.fail(path, e.what());
  }
}

Body read_rigid_body(const Reader& r, const json& b, const std::string& where) {
  Body body;
  body.rigid = true;
  const int d = read_translation(r, b, where);
  body.shape.translation = d;
  if (d > 0 || b.contains("mass")) body.shape.mass = r.positive(b, where, "mass");
  body.shape.inertia = read_inertia(r, b, where);
  if (b.contains("any_inertia")) {  // RigidBody::any_inertia: moments that no rigid body has, on purpose
    const json& v = b.at("any_inertia");
    if (!v.is_boolean()) r.fail(where + ".any_inertia", std::string("expected true or false, got ") + v.type_name());
    body.shape.any_inertia = v.get<bool>();
  }
  body.orientation = read_orientation(r, b, where);
  body.angular_velocity = r.vector3(b, where, "angular_velocity", false);
  for (const char* key : {"position", "velocity"})
    if (d == 0 && b.contains(key))
      r.fail(where + "." + key, "the body's centre is fixed (translation 0); give \"translation\": 2 or 3 to move it");
  if (d > 0) {
    body.position = r.numbers(b, where, "position", static_cast<std::size_t>(d), true);
    body.velocity = r.numbers(b, where, "velocity", static_cast<std::size_t>(d), false);
  }
  return body;
}

}  // namespace

void read_bodies(const Reader& r, const json& root, System& s) {
  if (!root.contains("bodies") || !root.at("bodies").is_array() || root.at("bodies").empty())
    r.fail("bodies", "missing (an array of at least one body is required)");
  const json& bodies = root.at("bodies");
  for (std::size_t i = 0; i < bodies.size(); ++i) {
    const std::string where = "bodies[" + std::to_string(i) + "]";
    const json& b = bodies[i];
    if (!b.is_object()) r.fail(where, "expected an object, got " + std::string(b.type_name()));
    bool rigid = false;
    if (b.contains("type")) {
      const json& t = b.at("type");
      if (!t.is_string()) r.fail(where + ".type", std::string("expected \"planar\" or \"rigid\", got ") + t.type_name());
      const std::string& type = t.get_ref<const std::string&>();
      if (type != "planar" && type != "rigid")
        r.fail(where + ".type", "unknown body type '" + type + "' (known: planar, rigid)");
      rigid = type == "rigid";
    }
    body_keys(r, b, where, rigid);
    r.text(b, where, "name");
    if (rigid) {
      s.bodies.push_back(read_rigid_body(r, b, where));
      continue;
    }
    const double zero = 0.0;
    const auto pos = r.numbers(b, where, "position", 2, true);
    const auto vel = r.numbers(b, where, "velocity", 2, false);
    Body body;
    body.mass = r.positive(b, where, "mass");
    body.inertia = r.positive(b, where, "inertia");
    body.x = pos[0];
    body.y = pos[1];
    body.heading = r.number(b, where, "heading", &zero);
    body.vx = vel[0];
    body.vy = vel[1];
    body.turn_rate = r.number(b, where, "turn_rate", &zero);
    s.bodies.push_back(body);
  }
}

}  // namespace nonholo::scenarios::scene_file
