#pragma once
// The dynamic schedule's shared counter: one long on the root rank, advanced with
// MPI_Fetch_and_op (passive target, so the root need not take part while it computes).
// On one node OpenMPI's shared-memory window makes a claim a CPU atomic (about 0.5 us
// measured); across nodes it is a network atomic, or waits for the root's next MPI call where
// the network has none.
#include <mpi.h>

namespace nonholo::detail {

class ClaimCounter {
 public:
  // Collective over comm (all ranks construct it together), counter at 0.
  ClaimCounter(MPI_Comm comm, int root);
  // Collective too (MPI_Win_free).
  ~ClaimCounter();
  ClaimCounter(const ClaimCounter&) = delete;
  ClaimCounter& operator=(const ClaimCounter&) = delete;

  // The counter's value before adding n to it. One thread at a time (the caller serialises).
  long claim(long n);

 private:
  MPI_Win window_ = MPI_WIN_NULL;
  int root_;
};

}  // namespace nonholo::detail
