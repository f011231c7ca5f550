// `mpirun nonholo batch` (mpi_batch.hpp): the ranks agree on one command in one reduction (naming the first
// line that differs), then run the trajectories with ensemble_for; a later failure aborts every rank.
#include "mpi_batch.hpp"

#include "fnv1a.hpp"

#include <nonholo/mpi_ensemble.hpp>

#include <cstdint>
#include <cstdlib>
#include <iostream>
#include <new>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace nonholo::scenarios {
namespace {

std::vector<std::string> lines_of(const std::string& text) {
  std::vector<std::string> lines;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  return lines;
}

// The first line in which `theirs` differs from `ours`, said as "rank 0 has X, rank r has Y".
std::string first_difference(const std::string& ours, const std::string& theirs, int rank) {
  const auto a = lines_of(ours), b = lines_of(theirs);
  for (std::size_t i = 0; i < std::max(a.size(), b.size()); ++i) {
    const std::string x = i < a.size() ? a[i] : "(nothing)", y = i < b.size() ? b[i] : "(nothing)";
    if (x != y) return "rank 0 has " + x + ", rank " + std::to_string(rank) + " has " + y;
  }
  return "rank " + std::to_string(rank) + " differs";
}

}  // namespace

MpiBatch::MpiBatch(MPI_Comm comm, const EnsembleOptions& options) : options_(options) {
  MPI_Comm_dup(comm, &comm_);
  MPI_Comm_rank(comm_, &rank_);
  MPI_Comm_size(comm_, &size_);
}

MpiBatch::~MpiBatch() { MPI_Comm_free(&comm_); }

void MpiBatch::agree(bool ok, const std::string& command) {
  agreed_ = true;
  // One reduction: the lowest rank that failed (size_ if none) and the least and the largest
  // hash of the commands (the largest as the least of its complement).
  const std::uint64_t h = fnv1a(command);
  std::uint64_t mine[3] = {static_cast<std::uint64_t>(ok ? size_ : rank_), h, ~h}, least[3] = {0, 0, 0};
  MPI_Allreduce(mine, least, 3, MPI_UINT64_T, MPI_MIN, comm_);
  const int failed = static_cast<int>(least[0]);
  failed_alone_ = !ok && failed == rank_ && rank_ != 0;
  if (failed == 0) throw std::runtime_error("rank 0 could not begin the batch");
  if (failed < size_)
    throw std::runtime_error("rank " + std::to_string(failed) + " of " + std::to_string(size_) +
                             " could not begin the batch (its own message says why)");
  if (least[1] != ~least[2])
    throw std::runtime_error("the ranks were not started with the same batch: " + difference(command) +
                             ": give every rank the same arguments (only --threads may differ)");
}

std::string MpiBatch::difference(const std::string& command) {
  const int length = static_cast<int>(command.size());
  std::vector<int> lengths(static_cast<std::size_t>(size_)), offsets(static_cast<std::size_t>(size_));
  MPI_Gather(&length, 1, MPI_INT, lengths.data(), 1, MPI_INT, 0, comm_);
  std::string all;
  if (rank_ == 0) {
    for (int r = 0, at = 0; r < size_; at += lengths[static_cast<std::size_t>(r)], ++r) offsets[static_cast<std::size_t>(r)] = at;
    all.resize(static_cast<std::size_t>(offsets.back() + lengths.back()));
  }
  MPI_Gatherv(command.data(), length, MPI_CHAR, all.data(), lengths.data(), offsets.data(), MPI_CHAR, 0, comm_);
  if (rank_ != 0) return "see rank 0";
  for (int r = 1; r < size_; ++r) {
    const std::string theirs = all.substr(static_cast<std::size_t>(offsets[static_cast<std::size_t>(r)]),
                                          static_cast<std::size_t>(lengths[static_cast<std::size_t>(r)]));
    if (theirs != command) return first_difference(command, theirs, r);
  }
  return "a hash collision";  // equal texts, different hashes: cannot happen
}

std::vector<EnsembleItem> MpiBatch::run(long count, int threads, const std::string& command, const EnsembleJob& job) {
  agree(true, command);
  EnsembleOptions options = options_;
  options.threads = threads;
  options.root = 0;
  // From here on the other ranks wait in the ensemble's collectives for this one: a failure
  // here cannot be reported through them, only by stopping the whole job.
  try {
    // Test hook (tests/test_mpi_batch.cpp): the named rank runs out of memory here.
    if (const char* r = std::getenv("NONHOLO_TEST_FAIL_RANK"); r && std::atoi(r) == rank_) throw std::bad_alloc();
    return ensemble_for(comm_, count, job, options);
  } catch (const std::exception& e) {
    std::cerr << "nonholo batch: rank " << rank_ << " of " << size_ << " failed during the batch: " << e.what()
              << ": stopping every rank (MPI_Abort)" << std::endl;
    MPI_Abort(comm_, 1);
    throw;  // not reached
  }
}

void MpiBatch::abandon() {
  if (agreed_) return;
  try {
    agree(false, "");
  } catch (const std::runtime_error&) {  // "rank r could not begin": this rank has its own message
  }
}

}  // namespace nonholo::scenarios
