#include <nonholo/scenarios/command_line.hpp>

#include <iostream>

#ifdef NONHOLO_WITH_MPI
#include "mpi_main.hpp"
#endif

int main(int argc, char** argv) {
#ifdef NONHOLO_WITH_MPI
  if (nonholo::scenarios::launched_by_mpi()) return nonholo::scenarios::mpi_main(argc, argv);
#endif
  return nonholo::scenarios::run_command_line(argc, argv, std::cout, std::cerr);
}
