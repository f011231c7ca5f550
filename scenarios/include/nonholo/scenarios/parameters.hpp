#pragma once
/// @file
/// Named scene parameters with defaults, set from the command line as NAME=VALUE.
#include <string>
#include <vector>

namespace nonholo::scenarios {

/// One parameter of a scene.
struct ParameterSpec {
  std::string name;  ///< NAME in NAME=VALUE
  double default_value;  ///< its value unless set
  std::string description;  ///< what it is (`nonholo list` shows it)
};

/// A scene's parameters, at their defaults until set.
class Parameters {
 public:
  /// The parameters `specs` of scene `scene` (named in messages), at their defaults.
  Parameters(std::string scene, std::vector<ParameterSpec> specs);

  /// Throws std::invalid_argument for an unknown name (listing the valid ones) or a
  /// non-finite value.
  void set(const std::string& name, double value);
  /// "NAME=VALUE", as given to `--set`.
  void assign(const std::string& assignment);

  double operator[](const std::string& name) const;  ///< the value; std::logic_error for an undeclared name
  /// Throws unless the parameter is finite and > 0 (>= 0 when allow_zero).
  double positive(const std::string& name, bool allow_zero = false) const;
  /// Throws unless the parameter is a whole number in [lo, hi].
  long whole(const std::string& name, long lo, long hi) const;
  /// Throws unless lo <= value <= hi.
  double within(const std::string& name, double lo, double hi) const;
  const std::vector<ParameterSpec>& specs() const { return specs_; }  ///< in declaration order
  const std::string& scene() const { return scene_; }  ///< the scene's name

 private:
  int index_of(const std::string& name) const;  // -1 if unknown
  std::string scene_;
  std::vector<ParameterSpec> specs_;
  std::vector<double> values_;
};

/// Strict decimal parse of the whole string; throws std::invalid_argument naming `context`.
double parse_number(const std::string& text, const std::string& context);

}  // namespace nonholo::scenarios
