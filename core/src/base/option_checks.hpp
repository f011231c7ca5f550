#pragma once
// The checks shared by the integrators' options. Each finds the first problem without
// allocating, so that a step can refuse bad options with a status (Status::InvalidOptions)
// and validate() can throw std::invalid_argument("<what> = <value> <rule>") from the same rule.
#include <nonholo/composition.hpp>

#include <cmath>
#include <sstream>
#include <stdexcept>

namespace nonholo::detail {

struct OptionProblem {
  const char* what = nullptr;  // nullptr: no problem
  double value = 0.0;
  const char* rule = nullptr;
  explicit operator bool() const { return what != nullptr; }
};

[[noreturn]] inline void reject(const char* what, double value, const char* rule) {
  std::ostringstream os;
  os << what << " = " << value << " " << rule;
  throw std::invalid_argument(os.str());
}
inline void reject_if(const OptionProblem& p) {
  if (p) reject(p.what, p.value, p.rule);
}

inline OptionProblem step_size_problem(double h) {
  if (!(h > 0.0) || !std::isfinite(h)) return {"step size h", h, "must be positive and finite"};
  return {};
}

inline OptionProblem pivot_ratio_problem(double ratio) {
  if (!(ratio >= 0.0) || !(ratio < 1.0)) return {"min_pivot_ratio", ratio, "must lie in [0, 1)"};
  return {};
}

inline OptionProblem newton_problem(double tolerance, int max_iterations) {
  if (!(tolerance > 0.0) || !(tolerance < 1.0)) return {"newton_tolerance", tolerance, "must lie in (0, 1)"};
  if (max_iterations < 1) return {"max_newton_iterations", static_cast<double>(max_iterations), "must be at least 1"};
  return {};
}

}  // namespace nonholo::detail

namespace nonholo {
struct RestartOptions;
struct RattleOptions;
namespace detail {
OptionProblem restart_problem(const RestartOptions& options);  // restart_options.cpp
OptionProblem rattle_problem(const RattleOptions& options);    // rattle_options.cpp
// The scheme of (order, composition) into `scheme`; false for a pair that has none (no throw).
bool find_composition(int order, Composition composition, CompositionScheme& scheme);  // composition.cpp
}  // namespace detail
}  // namespace nonholo
