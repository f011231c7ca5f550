#pragma once
// `mpirun nonholo batch`: the batch's trajectories over the ranks of a communicator, through
// the library's ensemble_for (nonholo/mpi_ensemble.hpp); rank 0 writes.
//
// Before the trajectories start, the ranks agree that every one of them got there: a rank
// that failed earlier (a --out that rank 0 cannot open, a scene file missing on one node)
// calls abandon() instead, and the others then stop too rather than wait for it forever.
#include <nonholo/ensemble.hpp>
#include <nonholo/scenarios/batch.hpp>

#include <mpi.h>

namespace nonholo::scenarios {

class MpiBatch final : public BatchProcesses {
 public:
  // comm is duplicated (and freed by the destructor, which MPI_Finalize must follow).
  MpiBatch(MPI_Comm comm, const EnsembleOptions& options);
  ~MpiBatch() override;
  MpiBatch(const MpiBatch&) = delete;
  MpiBatch& operator=(const MpiBatch&) = delete;

  int size() const override { return size_; }
  bool writes() const override { return rank_ == 0; }
  std::vector<EnsembleItem> run(long count, int threads, const EnsembleJob& job) override;
  void abandon() override;

  // This rank failed before the batch began and rank 0 did not: its own message is the one
  // to show (rank 0 only says which rank failed).
  bool failed_alone() const { return failed_alone_; }

 private:
  // Collective: the lowest rank that failed, or size_ when none did.
  int agree(bool ok);

  MPI_Comm comm_ = MPI_COMM_NULL;
  EnsembleOptions options_;
  int rank_ = 0, size_ = 1;
  bool agreed_ = false, failed_alone_ = false;
};

}  // namespace nonholo::scenarios
