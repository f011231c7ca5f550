#pragma once
// The `nonholo` command line driven in-process: exit code, stdout and stderr of one call.
#include <nonholo/scenarios/command_line.hpp>

#include <sstream>
#include <string>
#include <vector>

namespace nonholo::testing {

struct CliResult {
  int code;
  std::string out, err;
};

inline CliResult run_cli(std::vector<std::string> args) {
  args.insert(args.begin(), "nonholo");
  std::vector<const char*> argv;
  for (const auto& a : args) argv.push_back(a.c_str());
  std::ostringstream out, err;
  const int code = scenarios::run_command_line(static_cast<int>(argv.size()), argv.data(), out, err);
  return {code, out.str(), err.str()};
}

}  // namespace nonholo::testing
