#pragma once
// The `nonholo` command line, callable in-process (the tests drive it this way).
#include <iosfwd>

namespace nonholo::scenarios {

// Exit codes: 0 success, 1 bad arguments or input (message on err), 2 a step failed (the
// output written so far is kept and the summary says status=...).
int run_command_line(int argc, const char* const* argv, std::ostream& out, std::ostream& err);

}  // namespace nonholo::scenarios
