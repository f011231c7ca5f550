#pragma once
/// @file
/// The `nonholo` command line, callable in-process (the tests drive it this way).
#include <nonholo/scenarios/batch.hpp>
#include <nonholo/scenarios/run.hpp>

#include <iosfwd>
#include <string>
#include <vector>

namespace nonholo::scenarios {

/// Runs the `nonholo` command line with these arguments, writing to out and err.
/// Exit codes: 0 success, 1 bad arguments or input (message on err), 2 a step failed (the
/// output written so far is kept and the summary says status=...). With `processes` (MPI ranks
/// under mpirun, scenarios/cli/mpi_main.hpp), `batch` spreads its trajectories over them and
/// the other commands refuse to run on more than one.
int run_command_line(int argc, const char* const* argv, std::ostream& out, std::ostream& err,
                     BatchProcesses* processes = nullptr);

/// The options of `nonholo run` and `nonholo batch` (the scene and what follows it on the
/// command line), checked as the tool checks them: throws std::invalid_argument with the message
/// the tool would print. For callers that speak the tool's language (the Python package).
///@{
RunConfig parse_run_arguments(const std::vector<std::string>& args);
BatchConfig parse_batch_arguments(const std::vector<std::string>& args);
///@}

}  // namespace nonholo::scenarios
