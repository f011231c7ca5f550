#include <nonholo/scenarios/scene_file.hpp>

#include <nonholo/model_builder.hpp>
#include <nonholo/rigid_body.hpp>

#include <Eigen/Core>

#include <nlohmann/json.hpp>

#include <sys/stat.h>

#include <algorithm>
#include <cerrno>
#include <climits>
#include <cmath>
#include <cstring>
#include <fstream>
#include <memory>
#include <set>
#include <sstream>
#include <stdexcept>
#include <tuple>
#include <vector>

namespace nonholo::scenarios {
namespace {

using json = nlohmann::json;

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

// Keys and names from the file are echoed in messages: control characters are shown as
// \xNN rather than sent to the terminal.
std::string shown(const std::string& text) {
  std::string out;
  for (const char c : text) {
    const auto u = static_cast<unsigned char>(c);
    if (u >= 0x20 && u != 0x7f) {
      out += c;
    } else {
      const char* hex = "0123456789abcdef";
      out += {'\\', 'x', hex[u >> 4], hex[u & 15]};
    }
  }
  return out;
}

// Reads fields with errors that name the file and the path of the value.
class Reader {
 public:
  explicit Reader(std::string file) : file_(std::move(file)) {}
  [[noreturn]] void fail(const std::string& where, const std::string& what) const {
    throw std::invalid_argument(shown(file_ + ": " + where + ": " + what));
  }
  void keys(const json& j, const std::string& where, const std::set<std::string>& allowed) const {
    if (!j.is_object()) fail(where, "expected an object, got " + std::string(j.type_name()));
    for (auto it = j.begin(); it != j.end(); ++it)
      if (!allowed.count(it.key())) {
        std::string known;
        for (const auto& k : allowed) known += (known.empty() ? "" : ", ") + k;
        fail(where, "unknown key '" + it.key() + "' (known: " + known + ")");
      }
  }
  double number(const json& j, const std::string& where, const char* key, const double* fallback = nullptr) const {
    const std::string path = where + "." + key;
    if (!j.contains(key)) {
      if (fallback) return *fallback;
      fail(path, "missing (a number is required)");
    }
    const json& v = j.at(key);
    if (!v.is_number()) fail(path, std::string("expected a number, got ") + v.type_name());
    const double x = v.get<double>();
    if (!std::isfinite(x)) fail(path, "is not finite");
    return x;
  }
  double positive(const json& j, const std::string& where, const char* key) const {
    const double x = number(j, where, key);
    if (!(x > 0.0)) {
      std::ostringstream os;
      os << "must be positive, got " << x;
      fail(where + "." + key, os.str());
    }
    return x;
  }
  // A number of an array (or any value) at `path`: finite.
  double entry(const json& v, const std::string& path) const {
    if (!v.is_number()) fail(path, std::string("expected a number, got ") + v.type_name());
    const double x = v.get<double>();
    if (!std::isfinite(x)) fail(path, "is not finite");
    return x;
  }
  std::vector<double> numbers(const json& j, const std::string& where, const char* key, std::size_t n,
                              bool required) const {
    const std::string path = where + "." + key;
    if (!j.contains(key)) {
      if (required) fail(path, "missing (" + std::to_string(n) + " numbers are required)");
      return std::vector<double>(n, 0.0);
    }
    const json& v = j.at(key);
    if (!v.is_array() || v.size() != n)
      fail(path, "expected " + std::to_string(n) + " numbers, got " + count(v));
    std::vector<double> out;
    for (std::size_t i = 0; i < n; ++i) out.push_back(entry(v[i], path + "[" + std::to_string(i) + "]"));
    return out;
  }
  Eigen::Vector3d vector3(const json& j, const std::string& where, const char* key, bool required,
                          const Eigen::Vector3d& fallback = Eigen::Vector3d::Zero()) const {
    if (!j.contains(key) && !required) return fallback;
    const auto v = numbers(j, where, key, 3, required);
    return {v[0], v[1], v[2]};
  }
  // "3 entries" for an array, its type otherwise.
  static std::string count(const json& v) {
    return v.is_array() ? std::to_string(v.size()) + " entries" : std::string(v.type_name());
  }
  int body(const json& j, const std::string& where, const std::string& key, int bodies) const {
    const std::string path = where + "." + key;
    if (!j.is_number_integer()) fail(path, std::string("expected a body index, got ") + j.type_name());
    // An unsigned beyond LONG_MAX would wrap to a negative long.
    const long b = j.is_number_unsigned() && j.get<unsigned long>() > LONG_MAX ? LONG_MAX : j.get<long>();
    if (b < 0 || b >= bodies)
      fail(path, "body " + std::to_string(b) + " does not exist (the file has " + std::to_string(bodies) +
                     " bodies, 0 to " + std::to_string(bodies - 1) + ")");
    return static_cast<int>(b);
  }
  std::pair<int, int> pair(const json& j, const std::string& where, int bodies) const {
    if (!j.contains("bodies")) fail(where + ".bodies", "missing (two body indices are required)");
    const json& v = j.at("bodies");
    if (!v.is_array() || v.size() != 2)
      fail(where + ".bodies", "expected two body indices, got " + count(v));
    const int a = body(v[0], where, "bodies[0]", bodies), b = body(v[1], where, "bodies[1]", bodies);
    if (a == b) fail(where + ".bodies", "a body cannot be joined to itself");
    return {a, b};
  }
  void text(const json& j, const std::string& where, const char* key) const {
    if (j.contains(key) && !j.at(key).is_string())
      fail(where + "." + key, std::string("expected a string, got ") + j.at(key).type_name());
  }
  std::string type(const json& j, const std::string& where) const {
    if (!j.is_object()) fail(where, "expected an object, got " + std::string(j.type_name()));
    if (!j.contains("type") || !j.at("type").is_string()) fail(where + ".type", "missing (a string is required)");
    return j.at("type").get<std::string>();
  }

 private:
  std::string file_;
};

std::string line_and_column(const std::string& text, std::size_t byte) {
  std::size_t line = 1, column = 1;
  for (std::size_t i = 0; i < byte && i < text.size(); ++i) {
    if (text[i] == '\n') {
      ++line;
      column = 1;
    } else {
      ++column;
    }
  }
  return "line " + std::to_string(line) + ", column " + std::to_string(column);
}

[[noreturn]] void fail_at(const std::string& name, const std::string& text, std::size_t byte, const std::string& what) {
  throw std::invalid_argument(name + ": " + line_and_column(text, byte) + ": " + what);
}

// Refuses nesting deeper than kMaxSceneDepth before anything is built from the text, so
// no recursive operation on the document can exhaust the stack. Brackets count only
// outside strings.
void check_depth(const std::string& text, const std::string& name) {
  int depth = 0;
  bool in_string = false, escaped = false;
  for (std::size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (in_string) {
      if (escaped) escaped = false;
      else if (c == '\\') escaped = true;
      else if (c == '"') in_string = false;
    } else if (c == '"') {
      in_string = true;
    } else if (c == '[' || c == '{') {
      if (++depth > kMaxSceneDepth)
        fail_at(name, text, i, "arrays and objects nested deeper than " + std::to_string(kMaxSceneDepth) +
                                   " levels (a scene file needs 5)");
    } else if ((c == ']' || c == '}') && depth > 0) {
      --depth;  // an unbalanced one is the parser's syntax error
    }
  }
}

// Builds the document as json::parse would, but refuses a key given twice in one object
// (json::parse keeps the last silently), naming the object's path.
class DocumentBuilder : public nlohmann::json_sax<json> {
 public:
  DocumentBuilder(const std::string& name, const std::string& text) : name_(name), text_(text) {}
  json take() { return std::move(root_); }

  bool null() override { return add(json(nullptr)); }
  bool boolean(bool v) override { return add(json(v)); }
  bool number_integer(number_integer_t v) override { return add(json(v)); }
  bool number_unsigned(number_unsigned_t v) override { return add(json(v)); }
  bool number_float(number_float_t v, const string_t&) override { return add(json(v)); }
  bool string(string_t& v) override { return add(json(std::move(v))); }
  bool binary(binary_t& v) override { return add(json::binary(std::move(v))); }
  bool start_object(std::size_t) override { return open(json::object()); }
  bool start_array(std::size_t) override { return open(json::array()); }
  bool end_object() override { return close(); }
  bool end_array() override { return close(); }
  bool key(string_t& k) override {
    if (frames_.back().node->contains(k)) {
      const std::string where = path();
      throw std::invalid_argument(shown(name_ + ": " + (where.empty() ? "(top level)" : where) + ": duplicate key '" +
                                        k + "' (each key may appear once in an object)"));
    }
    key_ = std::move(k);
    return true;
  }
  bool parse_error(std::size_t byte, const std::string& token, const nlohmann::detail::exception& e) override {
    if (e.id == 406)  // "number overflow parsing '1e999'"; byte is the end of the token
      fail_at(name_, text_, byte >= token.size() ? byte - token.size() : 0,
              "the number " + token + " is not a finite double");
    // e.what() is "[json.exception.parse_error.101] parse error at line L, column C: ..."
    const std::string what = e.what();
    const auto colon = what.find(": ", what.find("parse error"));
    fail_at(name_, text_, byte > 0 ? byte - 1 : 0, colon == std::string::npos ? what : what.substr(colon + 2));
  }

 private:
  struct Frame {
    json* node;
    std::string key;    // its key in the parent object ...
    std::size_t index;  // ... or its index in the parent array
  };
  // Places v in the open array or object (or makes it the root); returns where it went.
  json* place(json&& v) {
    if (frames_.empty()) {
      root_ = std::move(v);
      return &root_;
    }
    json& parent = *frames_.back().node;
    if (parent.is_array()) {
      parent.push_back(std::move(v));
      return &parent.back();
    }
    return &(parent[key_] = std::move(v));
  }
  bool add(json&& v) {
    place(std::move(v));
    return true;
  }
  bool open(json&& v) {
    const bool in_array = !frames_.empty() && frames_.back().node->is_array();
    const std::size_t index = in_array ? frames_.back().node->size() : 0;
    std::string key = frames_.empty() || in_array ? std::string() : key_;
    frames_.push_back({place(std::move(v)), std::move(key), index});
    return true;
  }
  bool close() {
    frames_.pop_back();
    return true;
  }
  // The path of the innermost open object, as the Reader spells it: bodies[2].position.
  std::string path() const {
    std::string out;
    for (std::size_t i = 1; i < frames_.size(); ++i) {
      if (frames_[i - 1].node->is_array()) out += "[" + std::to_string(frames_[i].index) + "]";
      else out += (out.empty() ? "" : ".") + frames_[i].key;
    }
    return out;
  }

  const std::string& name_;
  const std::string& text_;
  json root_;
  std::vector<Frame> frames_;
  std::string key_;
};

// Reads the whole file after checking that it is a regular file within the size limit
// (a directory, /dev/zero or a pipe would otherwise fail oddly or be read for ever).
std::string read_file(const std::string& path) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0)
    throw std::invalid_argument(path + ": cannot be read: " + std::strerror(errno));
  if (!S_ISREG(st.st_mode)) {
    const char* kind = S_ISDIR(st.st_mode)    ? "a directory"
                       : S_ISCHR(st.st_mode)  ? "a character device"
                       : S_ISBLK(st.st_mode)  ? "a block device"
                       : S_ISFIFO(st.st_mode) ? "a FIFO (named pipe)"
                       : S_ISSOCK(st.st_mode) ? "a socket"
                                              : "not a regular file";
    throw std::invalid_argument(path + ": is " + std::string(kind) + "; a scene file must be a regular file");
  }
  const auto too_large = [&](const std::string& size) {
    throw std::invalid_argument(path + ": is " + size + "; a scene file may be at most " +
                                std::to_string(kMaxSceneFileBytes) + " bytes (" +
                                std::to_string(kMaxSceneFileBytes >> 20) + " MiB)");
  };
  if (static_cast<unsigned long long>(st.st_size) > kMaxSceneFileBytes) too_large(std::to_string(st.st_size) + " bytes");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::invalid_argument(path + ": cannot be read: " + std::strerror(errno));
  std::string text;
  text.reserve(static_cast<std::size_t>(st.st_size));
  char chunk[1 << 16];
  while (in.read(chunk, sizeof chunk) || in.gcount() > 0) {
    text.append(chunk, static_cast<std::size_t>(in.gcount()));
    if (text.size() > kMaxSceneFileBytes) too_large("over " + std::to_string(kMaxSceneFileBytes) + " bytes (it grew while being read)");
  }
  if (in.bad()) throw std::invalid_argument(path + ": cannot be read: " + std::strerror(errno));
  return text;
}

// The keys of each kind of body. A key of the other kind is refused with a message that
// says which kind it belongs to.
const std::set<std::string> kPlanarKeys{"type", "name", "mass", "inertia", "position", "heading", "velocity",
                                        "turn_rate"};
const std::set<std::string> kRigidKeys{"type",        "name",     "mass",             "inertia", "translation",
                                       "orientation", "position", "angular_velocity", "velocity"};

// Numbers in messages that ask for a value to be typed in: all 17 digits.
std::string exact(double x) {
  std::ostringstream os;
  os.precision(17);
  os << x;
  return os.str();
}

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

// The holonomic constraints must hold at the start: hitches closed, rods at their length,
// balls and disks on the ground. Elements the builder refuses anyway (a hitch on a rigid body,
// a rod between centres of different dimensions, a disk whose centre cannot rise) are left to
// it.
void check_closed(const Reader& r, const System& s) {
  for (const Constraint& c : s.constraints) {
    const std::string where = "constraints[" + std::to_string(c.index) + "]";
    const Body& a = s.bodies[static_cast<std::size_t>(c.a)];
    std::ostringstream os;
    switch (c.kind) {
      case Constraint::kHitch: {
        const Body& b = s.bodies[static_cast<std::size_t>(c.b)];
        if (a.rigid || b.rigid) break;
        const double gx = a.x - c.p * std::cos(a.heading) - b.x - c.p2 * std::cos(b.heading);
        const double gy = a.y - c.p * std::sin(a.heading) - b.y - c.p2 * std::sin(b.heading);
        const double gap = std::hypot(gx, gy);
        if (!(gap <= 1e-9 * (1.0 + std::abs(a.x) + std::abs(a.y)))) {  // NaN (overflow) is open too
          os << "the hitch is open at the start: its two points are " << gap << " apart (place body " << c.b
             << " so that they meet)";
          r.fail(where, os.str());
        }
        break;
      }
      case Constraint::kRod: {
        const std::vector<double> ca = a.centre(), cb = s.bodies[static_cast<std::size_t>(c.b)].centre();
        if (ca.empty() || ca.size() != cb.size()) break;
        double scale = 1.0 + c.p;
        for (std::size_t i = 0; i < ca.size(); ++i) scale = std::max({scale, std::abs(ca[i]), std::abs(cb[i])});
        const double dx = ca[0] - cb[0], dy = ca[1] - cb[1];
        const double distance = ca.size() == 3 ? std::hypot(dx, dy, ca[2] - cb[2]) : std::hypot(dx, dy);
        if (!(std::abs(distance - c.p) <= 1e-9 * scale)) {
          os << "the rod is not at its length at the start: the centres of bodies " << c.a << " and " << c.b << " are "
             << distance << " apart, the rod is " << c.p << " long (place body " << c.b << " at distance " << c.p
             << " from body " << c.a << ")";
          r.fail(where, os.str());
        }
        break;
      }
      case Constraint::kBall:
      case Constraint::kDisk: {
        if (!a.rigid || a.shape.translation != 3) break;
        const double z = a.position[2];
        const std::string set = "set bodies[" + std::to_string(c.a) + "].position[2] to ";
        if (c.kind == Constraint::kBall) {
          if (!(std::abs(z - c.p) <= 1e-9 * (1.0 + c.p + std::abs(z)))) {
            os << "the ball is not on the ground at the start: its centre is at height " << z << ", its radius is " << c.p
               << " (" << set << exact(c.p) << ")";
            r.fail(where, os.str());
          }
          break;
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
        break;
      }
      default:
        break;
    }
  }
}

System read_system(const std::string& text, const std::string& path) {
  if (text.size() > kMaxSceneFileBytes)
    throw std::invalid_argument(path + ": the text is " + std::to_string(text.size()) + " bytes; a scene file may be at most " +
                                std::to_string(kMaxSceneFileBytes) + " bytes");
  check_depth(text, path);
  json root;
  {
    DocumentBuilder builder(path, text);
    json::sax_parse(text, &builder);  // throws std::invalid_argument on any error
    root = builder.take();
  }
  const Reader r(path);
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
  const int n = static_cast<int>(s.bodies.size());
  auto list = [&](const char* key) -> json {
    if (!root.contains(key)) return json::array();
    if (!root.at(key).is_array()) r.fail(key, std::string("expected an array, got ") + root.at(key).type_name());
    return root.at(key);
  };
  const auto body_of = [&](const json& c, const std::string& where) {
    if (!c.contains("body")) r.fail(where + ".body", "missing (a body index is required)");
    return r.body(c.at("body"), where, "body", n);
  };
  const json constraints = list("constraints");
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
      k.a = body_of(c, where);
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
      k.a = body_of(c, where);
      k.axis = r.vector3(c, where, "axis", type == "body_axis", Eigen::Vector3d::UnitZ());
    } else if (type == "rolling_ball" || type == "rolling_disk") {
      r.keys(c, where, {"type", "body", "radius"});
      k.kind = type == "rolling_ball" ? Constraint::kBall : Constraint::kDisk;
      k.a = body_of(c, where);
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
  const json couplings = list("couplings");
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
  const json forces = list("forces");
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
            body_of(f, where), Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero(), 0.0, 0.0, i};
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
  check_closed(r, s);
  return s;
}

SceneSetup build_system(const System& s) {
  const int n = static_cast<int>(s.bodies.size());
  ModelBuilder b;
  // The builder's own checks, prefixed with the file and the element's path.
  const auto in = [&s](const std::string& where, const auto& add) {
    try {
      add();
    } catch (const std::invalid_argument& e) {
      throw std::invalid_argument(shown(s.file + ": " + where + ": " + e.what()));
    }
  };
  for (int i = 0; i < n; ++i) {
    const Body& body = s.bodies[static_cast<std::size_t>(i)];
    const std::string k = std::to_string(i);
    if (!body.rigid) {
      in("bodies[" + k + "]", [&] { b.add_planar_body({"x" + k, "y" + k, "theta" + k}, body.mass, body.inertia); });
      continue;
    }
    // Coordinates qw<i>, ..., z<i> by the body's index (as x<i> for a planar body); a name in
    // the file is only a comment.
    try {
      b.add_rigid_body(body.shape);
    } catch (const std::invalid_argument& e) {
      // The inertia alone refused (not symmetric, not positive definite, ill-conditioned), or
      // only with the mass (their ratio)?
      RigidBody alone;
      alone.inertia = body.shape.inertia;
      bool inertia = false;
      try {
        ModelBuilder().add_rigid_body(alone);
      } catch (const std::invalid_argument&) {
        inertia = true;
      }
      throw std::invalid_argument(shown(s.file + ": bodies[" + k + "]" + (inertia ? ".inertia" : "") + ": " + e.what()));
    }
  }
  // Local elements (nonholo/elements.hpp), their rows body by body (the one-body constraints of
  // body b, then those joining b to a later body) whatever the file's order: a chain written
  // in any order is streamed by the fused step (docs/design.md section 7). Each row is labelled with
  // its element of the file, for the messages of the set-up and of failed steps ("pivot of row
  // 7 of C (constraints[3] (knife_edge on body 2)) ...").
  std::vector<std::vector<const Constraint*>> of_body(static_cast<std::size_t>(n)), joining(static_cast<std::size_t>(n));
  for (const Constraint& c : s.constraints)
    (c.joins_two() ? joining[static_cast<std::size_t>(std::min(c.a, c.b))] : of_body[static_cast<std::size_t>(c.a)])
        .push_back(&c);
  const auto add = [&](const Constraint& c) {
    const std::string where = "constraints[" + std::to_string(c.index) + "]";
    const std::string label = where + " (" + c.label + ")";
    in(where, [&] {
      switch (c.kind) {
        case Constraint::kKnife: b.add_knife_edge({c.a, c.p}, label); break;
        case Constraint::kHitch: b.add_hitch({c.a, c.b, c.p, c.p2}, label); break;
        case Constraint::kBodyAxis: b.add_body_axis_constraint({c.a, c.axis}, label); break;
        case Constraint::kSpaceAxis: b.add_space_axis_constraint({c.a, c.axis}, label); break;
        case Constraint::kBall: b.add_rolling_ball({c.a, c.p}, label); break;
        case Constraint::kDisk: b.add_rolling_disk({c.a, c.p}, label); break;
        case Constraint::kRod: b.add_rod({c.a, c.b, c.p}, label); break;
      }
    });
  };
  for (int body = 0; body < n; ++body) {
    for (const Constraint* c : of_body[static_cast<std::size_t>(body)]) add(*c);
    for (const Constraint* c : joining[static_cast<std::size_t>(body)]) add(*c);
  }
  for (const Spring& sp : s.springs)
    in("couplings[" + std::to_string(sp.index) + "]", [&] { b.add_torsional_spring({sp.a, sp.b, sp.stiffness, sp.rest}); });
  for (const Drive& d : s.drives) {
    in("forces[" + std::to_string(d.index) + "]", [&] {
      const TimeFunction u = [d](double t) { return d.at(t); };
      const TimeVector v = [d](double t) { return d.vector_at(t); };
      switch (d.kind) {
        case Drive::kThrust: b.add_thrust({d.body, u, nullptr}); break;
        case Drive::kTorque: b.add_thrust({d.body, nullptr, u}); break;
        case Drive::kBodyTorque: b.add_body_torque({d.body, v}); break;
        case Drive::kBodyForce: b.add_body_force({d.body, v}); break;
        case Drive::kGravity: b.add_gravity(d.value[0]); break;
      }
    });
  }
  Model model = [&] {
    try {
      return std::move(b).build();
    } catch (const std::invalid_argument& e) {
      throw std::invalid_argument(shown(s.file + ": " + e.what()));
    }
  }();
  const int nq = model.num_configuration(), nv = model.num_velocities();
  SceneSetup setup{std::move(model), 0.0, Vector::Zero(nq), Vector::Zero(nv)};
  for (int i = 0; i < n; ++i) {
    const Body& body = s.bodies[static_cast<std::size_t>(i)];
    const auto& layout = setup.model.body(i);
    if (!body.rigid) {
      setup.q0.segment<3>(layout.q_offset) << body.x, body.y, body.heading;
      setup.v0.segment<3>(layout.offset) << body.vx, body.vy, body.turn_rate;
      continue;
    }
    setup.q0.segment<4>(layout.q_offset) = body.orientation;
    setup.v0.segment<3>(layout.offset) = body.angular_velocity;
    for (std::size_t j = 0; j < body.position.size(); ++j) {
      setup.q0[layout.q_offset + 4 + static_cast<int>(j)] = body.position[j];
      setup.v0[layout.offset + 3 + static_cast<int>(j)] = body.velocity[j];
    }
  }
  return setup;
}

}  // namespace

bool is_scene_file(const std::string& name) {
  return name.size() > 5 && name.compare(name.size() - 5, 5, ".json") == 0;
}

SceneInfo load_scene_file(const std::string& path) {
  return parse_scene_text(read_file(path), path);
}

SceneInfo parse_scene_text(const std::string& text, const std::string& path) {
  auto system = std::make_shared<System>(read_system(text, path));
  SceneInfo info;
  info.name = path;
  info.description = "scene file " + path;
  info.default_dt = system->dt;
  info.default_t_end = system->t_end;
  info.build = [system](const Parameters&) { return build_system(*system); };
  return info;
}

}  // namespace nonholo::scenarios
