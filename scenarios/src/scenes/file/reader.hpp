#pragma once
// A scene file's values read one at a time: each field checked for its type, range and
// presence, with errors that name the file and the path of the value ("bodies[2].mass").
#include <nlohmann/json.hpp>

#include <Eigen/Core>

#include <climits>
#include <cmath>
#include <set>
#include <sstream>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace nonholo::scenarios::scene_file {

using json = nlohmann::json;

// Keys and names from the file are echoed in messages: control characters are shown as
// \xNN rather than sent to the terminal.
inline std::string shown(const std::string& text) {
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

// Numbers in messages that ask for a value to be typed in: all 17 digits.
inline std::string exact(double x) {
  std::ostringstream os;
  os.precision(17);
  os << x;
  return os.str();
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

}  // namespace nonholo::scenarios::scene_file
