#include "mpi_batch.hpp"

#include <nonholo/mpi_ensemble.hpp>

#include <stdexcept>
#include <string>

namespace nonholo::scenarios {

MpiBatch::MpiBatch(MPI_Comm comm, const EnsembleOptions& options) : options_(options) {
  MPI_Comm_dup(comm, &comm_);
  MPI_Comm_rank(comm_, &rank_);
  MPI_Comm_size(comm_, &size_);
}

MpiBatch::~MpiBatch() { MPI_Comm_free(&comm_); }

int MpiBatch::agree(bool ok) {
  agreed_ = true;
  const int mine = ok ? size_ : rank_;
  int first = size_;
  MPI_Allreduce(&mine, &first, 1, MPI_INT, MPI_MIN, comm_);
  failed_alone_ = !ok && first == rank_ && rank_ != 0;
  return first;
}

std::vector<EnsembleItem> MpiBatch::run(long count, int threads, const EnsembleJob& job) {
  const int failed = agree(true);
  if (failed == 0) throw std::runtime_error("rank 0 could not begin the batch");
  if (failed < size_)
    throw std::runtime_error("rank " + std::to_string(failed) + " of " + std::to_string(size_) +
                             " could not begin the batch (its own message says why)");
  EnsembleOptions options = options_;
  options.threads = threads;
  options.root = 0;
  return ensemble_for(comm_, count, job, options);
}

void MpiBatch::abandon() {
  if (!agreed_) agree(false);
}

}  // namespace nonholo::scenarios
