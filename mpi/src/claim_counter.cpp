// The dynamic schedule's counter (claim_counter.hpp): a long in an MPI window on the root rank, claimed with
// MPI_Fetch_and_op under a passive-target lock.
#include "claim_counter.hpp"

namespace nonholo::detail {

ClaimCounter::ClaimCounter(MPI_Comm comm, int root) : root_(root) {
  int rank = 0;
  MPI_Comm_rank(comm, &rank);
  long* counter = nullptr;
  const MPI_Aint bytes = rank == root ? static_cast<MPI_Aint>(sizeof(long)) : 0;
  MPI_Win_allocate(bytes, sizeof(long), MPI_INFO_NULL, comm, &counter, &window_);
  if (rank == root) {  // a local store into the window needs an epoch of its own
    MPI_Win_lock(MPI_LOCK_EXCLUSIVE, root, 0, window_);
    *counter = 0;
    MPI_Win_unlock(root, window_);
  }
  MPI_Barrier(comm);  // nobody claims before the counter is 0
  MPI_Win_lock_all(MPI_MODE_NOCHECK, window_);
}

ClaimCounter::~ClaimCounter() {
  MPI_Win_unlock_all(window_);
  MPI_Win_free(&window_);
}

long ClaimCounter::claim(long n) {
  long before = 0;
  MPI_Fetch_and_op(&n, &before, MPI_LONG, root_, 0, MPI_SUM, window_);
  MPI_Win_flush(root_, window_);
  return before;
}

}  // namespace nonholo::detail
