#pragma once
// `nonholo batch`: many trajectories of one scene in parallel (OpenMP, nonholo/batch.hpp),
// each with its own parameters: the `run` options and --set apply to all, --vary NAME=LO:HI
// draws NAME uniformly in [LO, HI] per trajectory from the seed (the same draws whatever the
// thread count). One CSV row per trajectory, in trajectory order, byte-identical for any
// number of threads; then a summary line as `run` prints, with trajectories= and threads=.
#include <nonholo/scenarios/run.hpp>

#include <cstdint>
#include <iosfwd>
#include <string>
#include <vector>

namespace nonholo::scenarios {

struct BatchConfig {
  RunConfig run;  // scene, --set, --dt, --t-end, --method, --hitch, ... (csv_path unused)
  long count = 0;
  int threads = 0;  // 0: all cores
  std::vector<std::string> vary;  // NAME=LO:HI
  std::uint64_t seed = 1;
  std::string out;  // the per-trajectory CSV (empty: none)
};

struct BatchResult {
  RunSummary aggregate;  // max of the errors, total steps, wall time of the whole batch
  long trajectories = 0;
  int threads = 0;
  long failed = 0;
  std::string first_failure;  // "trajectory i: ..." of the first failed one
  std::string line() const;   // the summary line

  // What the CSV holds, one entry per trajectory in order: the varied parameters' values
  // (named in `varied`), the first coordinates of the final state (named in `shown`, at most
  // three: body 0's; NaN when the trajectory was not set up) and the trajectory's summary.
  struct Trajectory {
    std::vector<double> values;
    std::vector<double> final_q;
    RunSummary summary;
  };
  std::vector<std::string> varied, shown;
  std::vector<Trajectory> rows;
};

// Throws std::invalid_argument on bad options (before integrating).
BatchResult run_batch(const BatchConfig& config);

}  // namespace nonholo::scenarios
