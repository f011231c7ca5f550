#pragma once
/// @file
/// `nonholo wp`: what accuracy costs, for every method (docs/design.md §2; issue "speed
/// against error"). Writes CSV files into a directory; tools/work_precision.py draws them.
/// ~~~{.unparsed}
///   work_precision.csv  one row per (scene, method, step size or tolerance): CPU time,
///                       evaluations, max error against the oracle, energy errors, residual
///   long_time.csv       energy errors and residual against time over long runs
///   paper_*.csv         the paper's experiments (particle energy, sleigh error, snakeboard)
/// ~~~
#include <iosfwd>
#include <string>

namespace nonholo::scenarios {

/// The options of `nonholo wp`.
struct WorkPrecisionConfig {
  std::string directory = "wp";  ///< where the CSV files go
  bool quick = false;  ///< a few points per method and short long-time runs (for tests)
};

/// Throws std::invalid_argument if the directory cannot be written. Progress goes to `log`.
void run_work_precision(const WorkPrecisionConfig& config, std::ostream& log);

}  // namespace nonholo::scenarios
