// The `nonholo` executable: animate and view go to Python, a process mpirun started to mpi_main, the rest to
// run_command_line (<nonholo/scenarios/command_line.hpp>).
#include <nonholo/scenarios/command_line.hpp>

#include <iostream>

#include "python_commands.hpp"

#ifdef NONHOLO_WITH_MPI
#include "mpi_main.hpp"
#endif

int main(int argc, char** argv) {
  int exit_code = 0;
  if (nonholo::scenarios::run_python_command(argc, argv, &exit_code)) return exit_code;
#ifdef NONHOLO_WITH_MPI
  if (nonholo::scenarios::launched_by_mpi()) return nonholo::scenarios::mpi_main(argc, argv);
#endif
  return nonholo::scenarios::run_command_line(argc, argv, std::cout, std::cerr);
}
