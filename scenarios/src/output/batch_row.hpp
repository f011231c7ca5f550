#pragma once
// One trajectory's row of `nonholo batch`, and the row as bytes: what a rank sends the
// writing rank under MPI (BatchProcesses), so that its table is the one a single process
// would have made, bit for bit.
#include <nonholo/archive.hpp>
#include <nonholo/scenarios/run_types.hpp>
#include <nonholo/types.hpp>

#include <string>
#include <vector>

namespace nonholo::scenarios {

struct Row {
  RunSummary summary;
  std::vector<double> values;  // the varied parameters
  Vector final_q, final_p;
  std::vector<std::string> names;  // body 0's coordinates (first three), once set up
  std::vector<std::string> coordinates, velocities;  // all of them (BatchConfig::keep_states)
  std::string error;
};

// The whole row but final_q past its first three entries (all the table shows), unless
// `whole_state` (BatchConfig::keep_states): then final_q and final_p whole, and their names.
std::string pack_row(const Row& row, bool whole_state = false);
// Throws std::logic_error on bytes that pack_row did not make.
Row unpack_row(const std::string& bytes);

// The summary alone, every field (checkpoints).
void save(OutArchive& a, const RunSummary& summary);
void load(InArchive& a, RunSummary& summary);

}  // namespace nonholo::scenarios
