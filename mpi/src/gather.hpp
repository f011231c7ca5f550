#pragma once
// The results of ensemble_for's jobs, from the ranks that ran them to the root.
#include <nonholo/ensemble.hpp>

#include <mpi.h>

#include <vector>

namespace nonholo::detail {

// One job done on this rank.
struct DoneJob {
  long index;
  EnsembleItem item;
};

// Collective: every rank's jobs to `root`, which returns all `count` items in index order
// (each index must have been done on exactly one rank); the other ranks return nothing.
std::vector<EnsembleItem> gather_items(MPI_Comm comm, int root, long count, std::vector<DoneJob> done);

}  // namespace nonholo::detail
