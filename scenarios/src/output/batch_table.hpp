#pragma once
// The batch's table as CSV (`nonholo batch --out FILE.csv`): one row per trajectory with its
// varied values, final time, body 0's first coordinates and errors; and the journal of rows as
// they finish (OUT.partial.csv), so that a killed batch keeps every trajectory that finished.
#include <nonholo/scenarios/batch_types.hpp>

#include <fstream>
#include <mutex>
#include <ostream>
#include <string>
#include <vector>

namespace nonholo::scenarios {

// The batch's table as CSV: one row per trajectory, in order. Throws std::runtime_error on a
// write error.
void write_batch_csv(std::ofstream& out, const std::string& path, const BatchResult& result, bool error_estimate);

// Rows as trajectories finish, in the order they finish, flushed one by one, beside the batch's
// output (OUT.partial.csv; under MPI each rank its own, OUT.partial.rankR.csv): a batch killed
// before it ends keeps every trajectory that finished (nonholo.load reads the file; the rows
// carry their trajectory index). Removed once the output is written.
class Journal {
 public:
  // No journal without an output; throws std::invalid_argument when the file cannot be opened.
  Journal(const std::string& out, const BatchProcesses* processes, bool error_estimate);
  // A finished row (several threads: one at a time). The header comes with the first: its
  // names (body 0's coordinates) are known once a trajectory was set up.
  void add(long i, const BatchResult::Trajectory& row, const std::vector<std::string>& varied,
           const std::vector<std::string>& names);
  void remove();

 private:
  std::string path_;
  std::ofstream file_;
  std::mutex mutex_;
  bool header_ = false, has_work_ = false, error_estimate_;
};

}  // namespace nonholo::scenarios
