#pragma once
/// @file
/// Independent jobs spread over processes (MPI ranks), OpenMP threads within each: the types
/// that need no MPI, so that code which only hands jobs on (the scenes' batch) does not include
/// `<mpi.h>`. The function that runs them, ensemble_for, is in `<nonholo/mpi_ensemble.hpp>`
/// (target nonholo::mpi, built when MPI is found).
#include <functional>
#include <string>

namespace nonholo {

/// How the indices are split over the ranks.
enum class EnsembleSchedule {
  Static,   ///< one contiguous block per rank, fixed up front: no messages until the gather
  Dynamic,  ///< chunks claimed from a counter on the root (MPI one-sided) as threads free up
};

/// How ensemble_for runs its jobs.
struct EnsembleOptions {
  int threads = 0;  ///< OpenMP threads per rank (0: the cores this rank may use)
  /// Dynamic: within 2% of the ideal on jobs 100x apart in cost, where Static took 1.46x as
  /// long when the cost grew with the index (README "MPI ensembles"). Static sends no message
  /// while the jobs run.
  EnsembleSchedule schedule = EnsembleSchedule::Dynamic;
  long chunk = 0;  ///< Dynamic: indices per claim (0: about 64 claims per thread, as parallel_for)
  int root = 0;    ///< the rank that gets the results (and holds the counter)
};

/// One job's result: the bytes it returned, or the text of the exception it threw.
struct EnsembleItem {
  std::string data;   ///< the bytes the job returned ("" when it threw)
  std::string error;  ///< "" when the job returned
};

/// Job i on thread `thread` of its rank; returns its result as bytes, for the root.
using EnsembleJob = std::function<std::string(long i, int thread)>;

}  // namespace nonholo
