#pragma once
// The checks shared by the integrators' validate() functions: each throws
// std::invalid_argument("<what> = <value> <rule>").
#include <cmath>
#include <sstream>
#include <stdexcept>

namespace nonholo::detail {

[[noreturn]] inline void reject(const char* what, double value, const char* rule) {
  std::ostringstream os;
  os << what << " = " << value << " " << rule;
  throw std::invalid_argument(os.str());
}

inline void check_step_size(double h) {
  if (!(h > 0.0) || !std::isfinite(h)) reject("step size h", h, "must be positive and finite");
}

inline void check_pivot_ratio(double ratio) {
  if (!(ratio >= 0.0) || !(ratio < 1.0)) reject("min_pivot_ratio", ratio, "must lie in [0, 1)");
}

inline void check_newton(double tolerance, int max_iterations) {
  if (!(tolerance > 0.0) || !(tolerance < 1.0)) reject("newton_tolerance", tolerance, "must lie in (0, 1)");
  if (max_iterations < 1) reject("max_newton_iterations", max_iterations, "must be at least 1");
}

}  // namespace nonholo::detail
