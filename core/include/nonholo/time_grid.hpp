#pragma once
/// @file
/// The times of a run of equal steps, t_k = t0 + k h, computed rather than summed: adding h
/// ten million times drifts by thousands of ulps (10^7 steps of 1e-3 ended at 10000.0000016),
/// t0 + k h is within one rounding of the true time at every k. A step of another size, or a
/// t changed by hand, starts a new grid at the current time.
#include <limits>

namespace nonholo {

/// The grid t_k = t0 + k h a run's time is on.
struct TimeGrid {
  double t0 = std::numeric_limits<double>::quiet_NaN();  ///< NaN: no grid yet
  double h = 0.0;  ///< the grid's step size
  long k = 0;  ///< steps taken on this grid

  /// The time one step of size h after t; the grid is (re)anchored at t when needed.
  double next(double t, double step) {
    if (step != h || !(t0 + static_cast<double>(k) * h == t)) {
      t0 = t;
      h = step;
      k = 0;
    }
    return t0 + static_cast<double>(k + 1) * h;
  }
  /// After the step that next() timed has succeeded.
  void advance() { ++k; }
};

}  // namespace nonholo
