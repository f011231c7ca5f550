#pragma once
// `mpirun nonholo batch`: the batch's trajectories over the ranks of a communicator, through
// the library's ensemble_for (nonholo/mpi_ensemble.hpp); rank 0 writes.
//
// No failure on one rank leaves the others waiting. Before the trajectories start, the ranks
// agree, in the first collective of the batch, that every one of them got there and runs the
// same command (the canonical options, BatchConfig::command): a rank that failed earlier (bad
// arguments, a --out that rank 0 cannot open, a scene file missing on one node, another
// command) calls abandon() instead (mpi_main does it for a rank that returns without either),
// and the others then stop too; different commands stop every rank, naming the first option
// that differs. A failure after that, when the others are inside the ensemble's collectives
// (out of memory), prints the rank and the cause and calls MPI_Abort.
#include <nonholo/ensemble.hpp>
#include <nonholo/scenarios/batch.hpp>

#include <mpi.h>

#include <string>

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
  int rank() const override { return rank_; }
  std::vector<EnsembleItem> run(long count, int threads, const std::string& command, const EnsembleJob& job) override;
  // Takes part in the agreement as a rank that failed (no-op after it); does not throw.
  void abandon() override;

  // This rank failed before the batch began and rank 0 did not: its own message is the one
  // to show (rank 0 only says which rank failed).
  bool failed_alone() const { return failed_alone_; }

 private:
  // Collective: throws on every rank unless every rank is ok and runs `command`.
  void agree(bool ok, const std::string& command);
  // Collective, after the ranks found different commands: what differs, said on rank 0.
  std::string difference(const std::string& command);

  MPI_Comm comm_ = MPI_COMM_NULL;
  EnsembleOptions options_;
  int rank_ = 0, size_ = 1;
  bool agreed_ = false, failed_alone_ = false;
};

}  // namespace nonholo::scenarios
