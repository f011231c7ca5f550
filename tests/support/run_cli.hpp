#pragma once
// The `nonholo` command line driven in-process: exit code, stdout and stderr of one call.
#include <nonholo/scenarios/command_line.hpp>

#include <map>
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

// The key=value pairs of a summary line.
inline std::map<std::string, std::string> summary_fields(const std::string& line) {
  std::map<std::string, std::string> kv;
  std::istringstream in(line);
  std::string field;
  while (in >> field)
    if (const auto eq = field.find('='); eq != std::string::npos) kv[field.substr(0, eq)] = field.substr(eq + 1);
  return kv;
}

}  // namespace nonholo::testing
