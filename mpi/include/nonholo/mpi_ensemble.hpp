#pragma once
/// @file
/// Independent jobs over the ranks of an MPI communicator, OpenMP threads within each rank:
/// what parallel_for (nonholo/batch.hpp) does for threads, ensemble_for does for ranks. Only
/// with MPI (target nonholo::mpi, CMake option NONHOLO_WITH_MPI); the types are in
/// nonholo/ensemble.hpp.
#include <nonholo/ensemble.hpp>

#include <mpi.h>

#include <vector>

namespace nonholo {

/// Collective over `comm`: every rank calls it with the same count and options. Runs
/// job(i, thread) exactly once for every i in [0, count), on some rank, with options.threads
/// threads on each, and returns on options.root every job's item in index order (an empty
/// vector on the other ranks). A job that throws gets the exception's text as its item's error;
/// the others run on. The items do not depend on the ranks, threads or schedule when each job's
/// result does not depend on where it runs.
//
/// `comm` is duplicated for the call (MPI_Comm_dup): the ensemble's messages never meet the
/// caller's, and any communicator works (MPI_COMM_WORLD, a split of it, ...). MPI must be
/// initialised: MPI_THREAD_FUNNELED suffices for the static schedule or one thread per rank;
/// the dynamic schedule with more (options.threads other than 1) claims work from any of them
/// and needs MPI_THREAD_SERIALIZED. Throws std::invalid_argument on bad arguments or too little thread
/// support, on every rank alike and before any message.
std::vector<EnsembleItem> ensemble_for(MPI_Comm comm, long count, const EnsembleJob& job,
                                       const EnsembleOptions& options = {});

}  // namespace nonholo
