#pragma once
// The command line under mpirun (NONHOLO_WITH_MPI): MPI is initialised only when a launcher
// started the process, so a plain `nonholo run` never touches MPI (a singleton MPI_Init costs
// about 0.35 s with OpenMPI 4.1 here, and `run` has nothing to spread).
namespace nonholo::scenarios {

// Whether an MPI launcher (mpirun, mpiexec, srun) started this process: its environment says.
bool launched_by_mpi();

// MPI_Init_thread, the command line with `batch` spread over the ranks (mpi_batch.hpp), rank 0's
// output only, MPI_Finalize; returns this rank's exit code.
int mpi_main(int argc, char** argv);

}  // namespace nonholo::scenarios
