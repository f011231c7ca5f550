#pragma once
/// @file
/// `nonholo batch`: many trajectories of one scene in parallel (OpenMP, nonholo/batch.hpp),
/// each with its own parameters: the `run` options and `--set` apply to all, `--vary NAME=LO:HI`
/// draws NAME uniformly in [LO, HI] per trajectory from the seed (the same draws whatever the
/// thread count). One CSV row per trajectory, in trajectory order, byte-identical for any
/// number of threads; then a summary line as `run` prints, with trajectories= and threads=.
/// Under `mpirun`, the trajectories are spread over the ranks too (BatchProcesses).
#include <nonholo/scenarios/batch_types.hpp>
#include <nonholo/scenarios/run.hpp>

#include <cstddef>
#include <vector>

namespace nonholo::scenarios {

/// The bytes a batch keeps per trajectory until it ends, from the real sizes: its table row
/// (BatchResult::Trajectory), its error slot, the heap blocks of its varied values and shown
/// coordinates and, on the writing process of an MPI batch, the row's bytes as received
/// (EnsembleItem). A lower bound: messages and warnings longer than a string's inline buffer
/// add their length. tests/test_batch_memory.cpp measures the peak against it.
double batch_bytes_per_trajectory(std::size_t varied, bool mpi_writer);
/// Throws std::invalid_argument when count times that exceeds the machine's memory (the batch
/// would die of std::bad_alloc after its trajectories ran).
void check_batch_memory(const BatchConfig& config);

/// Throws std::invalid_argument on bad options (before integrating).
BatchResult run_batch(const BatchConfig& config);

/// The values trajectory `trajectory` of this batch draws for its varied parameters (`vary`, in
/// order): uniform in [LO, HI] from the seed and the trajectory alone, whatever the threads.
/// Throws std::invalid_argument for a malformed NAME=LO:HI.
std::vector<double> batch_draws(const BatchConfig& config, long trajectory);

}  // namespace nonholo::scenarios
