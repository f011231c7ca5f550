// The command line under mpirun (mpi_main.hpp): a launcher recognised by its environment, MPI initialised,
// the command run on every rank with rank 0's output only, MPI finalised.
#include "mpi_main.hpp"

#include <nonholo/scenarios/command_line.hpp>

#include <cstdlib>
#include <iostream>
#include <sstream>

#include "mpi_batch.hpp"

namespace nonholo::scenarios {

bool launched_by_mpi() {
  // OpenMPI's mpirun, PMIx launchers (srun --mpi=pmix, prterun), PMI-1/2 launchers.
  for (const char* name : {"OMPI_COMM_WORLD_SIZE", "PMIX_RANK", "PMI_RANK"})
    if (std::getenv(name)) return true;
  return false;
}

int mpi_main(int argc, char** argv) {
  int provided = MPI_THREAD_SINGLE;
  MPI_Init_thread(&argc, &argv, MPI_THREAD_SERIALIZED, &provided);
  EnsembleOptions options;
  if (provided < MPI_THREAD_SERIALIZED) options.schedule = EnsembleSchedule::Static;  // needs no claims from threads
  int code = 0;
  {
    MpiBatch batch(MPI_COMM_WORLD, options);
    // A rank that returns without beginning the batch (bad arguments, another command, --help)
    // still takes part in the ranks' agreement, so that the others do not wait for it.
    if (batch.writes()) {
      code = run_command_line(argc, argv, std::cout, std::cerr, &batch);
      batch.abandon();
    } else {  // the other ranks print nothing, unless they alone failed
      std::ostringstream out, err;
      code = run_command_line(argc, argv, out, err, &batch);
      batch.abandon();
      if (batch.failed_alone()) std::cerr << err.str() << std::flush;
    }
  }
  MPI_Finalize();
  return code;
}

}  // namespace nonholo::scenarios
