#pragma once
// The files a test writes: a path in the temporary directory that names the test and this
// process (tests run in parallel), and a file's bytes to compare outputs with.
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

namespace nonholo::testing {

inline std::string temp_path(const std::string& test, const std::string& name) {
  return (std::filesystem::temp_directory_path() / ("nonholo_" + test + "_" + std::to_string(::getpid()) + "_" + name))
      .string();
}

inline std::string bytes_of(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream os;
  os << in.rdbuf();
  return os.str();
}

}  // namespace nonholo::testing
