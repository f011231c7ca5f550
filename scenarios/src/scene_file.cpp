#include <nonholo/scenarios/scene_file.hpp>

#include <nonholo/model_builder.hpp>

#include <nlohmann/json.hpp>

#include <sys/stat.h>

#include <cerrno>
#include <climits>
#include <cmath>
#include <cstring>
#include <fstream>
#include <memory>
#include <set>
#include <sstream>
#include <stdexcept>
#include <vector>

namespace nonholo::scenarios {
namespace {

using json = nlohmann::json;

struct Body {
  double mass, inertia, x, y, heading, vx, vy, turn_rate;
};
struct Knife {
  int body;
  double offset;
  std::size_t index;  // in "constraints", for messages
};
struct Hitch {
  int a, b;
  double rear, front;
  std::size_t index;
};
struct Spring {
  int a, b;
  double stiffness, rest;
};
struct Drive {
  bool thrust;
  int body;
  double value, amplitude, omega, phase;
  double at(double t) const { return value + amplitude * std::sin(omega * t + phase); }
};
struct System {
  std::vector<Body> bodies;
  std::vector<Knife> knives;
  std::vector<Hitch> hitches;
  std::vector<Spring> springs;
  std::vector<Drive> drives;
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
  std::vector<double> numbers(const json& j, const std::string& where, const char* key, std::size_t n,
                              bool required) const {
    const std::string path = where + "." + key;
    if (!j.contains(key)) {
      if (required) fail(path, "missing (" + std::to_string(n) + " numbers are required)");
      return std::vector<double>(n, 0.0);
    }
    const json& v = j.at(key);
    if (!v.is_array() || v.size() != n)
      fail(path, "expected " + std::to_string(n) + " numbers, got " +
                     (v.is_array() ? std::to_string(v.size()) + " entries" : std::string(v.type_name())));
    std::vector<double> out;
    for (std::size_t i = 0; i < n; ++i) {
      if (!v[i].is_number()) fail(path + "[" + std::to_string(i) + "]", std::string("expected a number, got ") + v[i].type_name());
      out.push_back(v[i].get<double>());
      if (!std::isfinite(out.back())) fail(path + "[" + std::to_string(i) + "]", "is not finite");
    }
    return out;
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
      fail(where + ".bodies", "expected two body indices, got " +
                                  (v.is_array() ? std::to_string(v.size()) + " entries" : std::string(v.type_name())));
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
                                   " levels (a scene file needs 4)");
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
    r.keys(b, where, {"name", "mass", "inertia", "position", "heading", "velocity", "turn_rate"});
    r.text(b, where, "name");
    const double zero = 0.0;
    const auto pos = r.numbers(b, where, "position", 2, true);
    const auto vel = r.numbers(b, where, "velocity", 2, false);
    s.bodies.push_back({r.positive(b, where, "mass"), r.positive(b, where, "inertia"), pos[0], pos[1],
                        r.number(b, where, "heading", &zero), vel[0], vel[1], r.number(b, where, "turn_rate", &zero)});
  }
  const int n = static_cast<int>(s.bodies.size());
  auto list = [&](const char* key) -> json {
    if (!root.contains(key)) return json::array();
    if (!root.at(key).is_array()) r.fail(key, std::string("expected an array, got ") + root.at(key).type_name());
    return root.at(key);
  };
  const json constraints = list("constraints");
  for (std::size_t i = 0; i < constraints.size(); ++i) {
    const std::string where = "constraints[" + std::to_string(i) + "]";
    const json& c = constraints[i];
    const std::string type = r.type(c, where);
    if (type == "knife_edge") {
      r.keys(c, where, {"type", "body", "offset"});
      if (!c.contains("body")) r.fail(where + ".body", "missing (a body index is required)");
      const double zero = 0.0;
      s.knives.push_back({r.body(c.at("body"), where, "body", n), r.number(c, where, "offset", &zero), i});
    } else if (type == "hitch") {
      r.keys(c, where, {"type", "bodies", "rear", "front"});
      const auto [a, b] = r.pair(c, where, n);
      s.hitches.push_back({a, b, r.number(c, where, "rear"), r.number(c, where, "front"), i});
    } else {
      r.fail(where + ".type", "unknown constraint type '" + type + "' (known: knife_edge, hitch)");
    }
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
    s.springs.push_back({a, b, r.positive(c, where, "stiffness"), r.number(c, where, "rest_angle", &zero)});
  }
  const json forces = list("forces");
  for (std::size_t i = 0; i < forces.size(); ++i) {
    const std::string where = "forces[" + std::to_string(i) + "]";
    const json& f = forces[i];
    const std::string type = r.type(f, where);
    if (type != "thrust" && type != "torque")
      r.fail(where + ".type", "unknown force type '" + type + "' (known: thrust, torque)");
    r.keys(f, where, {"type", "body", "value", "amplitude", "omega", "phase"});
    if (!f.contains("body")) r.fail(where + ".body", "missing (a body index is required)");
    const double zero = 0.0;
    s.drives.push_back({type == "thrust", r.body(f.at("body"), where, "body", n), r.number(f, where, "value", &zero),
                        r.number(f, where, "amplitude", &zero), r.number(f, where, "omega", &zero),
                        r.number(f, where, "phase", &zero)});
  }
  // Hitches must be closed at the start.
  for (const Hitch& h : s.hitches) {
    const Body &a = s.bodies[static_cast<std::size_t>(h.a)], &b = s.bodies[static_cast<std::size_t>(h.b)];
    const double gx = a.x - h.rear * std::cos(a.heading) - b.x - h.front * std::cos(b.heading);
    const double gy = a.y - h.rear * std::sin(a.heading) - b.y - h.front * std::sin(b.heading);
    const double gap = std::hypot(gx, gy);
    if (!(gap <= 1e-9 * (1.0 + std::abs(a.x) + std::abs(a.y)))) {  // NaN (overflow) is open too
      std::ostringstream os;
      os << "the hitch is open at the start: its two points are " << gap
         << " apart (place body " << h.b << " so that they meet)";
      r.fail("constraints[" + std::to_string(h.index) + "]", os.str());
    }
  }
  return s;
}

SceneSetup build_system(const System& s) {
  const int n = static_cast<int>(s.bodies.size());
  ModelBuilder b;
  for (int i = 0; i < n; ++i) {
    const std::string k = std::to_string(i);
    try {
      b.add_planar_body({"x" + k, "y" + k, "theta" + k}, s.bodies[static_cast<std::size_t>(i)].mass,
                        s.bodies[static_cast<std::size_t>(i)].inertia);
    } catch (const std::invalid_argument& e) {  // say, an ill-conditioned mass block
      throw std::invalid_argument(s.file + ": bodies[" + k + "]: " + e.what());
    }
  }
  // Each row is labelled with its element of the file, for the messages of the set-up and
  // of failed steps ("pivot of row 7 of C (constraints[3] (knife_edge on body 2)) ...").
  const auto label = [](std::size_t index, const std::string& what) {
    return "constraints[" + std::to_string(index) + "] (" + what + ")";
  };
  // Local elements (nonholo/elements.hpp), their rows body by body (the knife edges of body
  // b, then the hitches from b to a later body) whatever the file's order: a chain written
  // in any order is streamed by the fused step (DESIGN.md section 7).
  std::vector<std::vector<const Knife*>> knives_of(static_cast<std::size_t>(n));
  std::vector<std::vector<const Hitch*>> hitches_of(static_cast<std::size_t>(n));
  for (const Knife& k : s.knives) knives_of[static_cast<std::size_t>(k.body)].push_back(&k);
  for (const Hitch& h : s.hitches) hitches_of[static_cast<std::size_t>(std::min(h.a, h.b))].push_back(&h);
  for (int body = 0; body < n; ++body) {
    for (const Knife* k : knives_of[static_cast<std::size_t>(body)])
      b.add_knife_edge({k->body, k->offset}, label(k->index, "knife_edge on body " + std::to_string(k->body)));
    for (const Hitch* h : hitches_of[static_cast<std::size_t>(body)])
      b.add_hitch({h->a, h->b, h->rear, h->front},
                  label(h->index, "hitch of bodies " + std::to_string(h->a) + " and " + std::to_string(h->b)));
  }
  for (const Spring& sp : s.springs) b.add_torsional_spring({sp.a, sp.b, sp.stiffness, sp.rest});
  for (const Drive& d : s.drives) {
    const TimeFunction u = [d](double t) { return d.at(t); };
    b.add_thrust(d.thrust ? Thrust{d.body, u, nullptr} : Thrust{d.body, nullptr, u});
  }
  SceneSetup setup{std::move(b).build(), 0.0, Vector::Zero(3 * n), Vector::Zero(3 * n)};
  for (int i = 0; i < n; ++i) {
    const Body& body = s.bodies[static_cast<std::size_t>(i)];
    setup.q0.segment<3>(3 * i) << body.x, body.y, body.heading;
    setup.v0.segment<3>(3 * i) << body.vx, body.vy, body.turn_rate;
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
