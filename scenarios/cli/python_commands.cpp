// `nonholo animate` and `nonholo view` (python_commands.hpp): `python3 -m` their module, spawned with the
// package on PYTHONPATH, its exit code passed on.
#include "python_commands.hpp"

#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <iostream>
#include <string>
#include <vector>

extern char** environ;

namespace nonholo::scenarios {
namespace {

// The module of each command inside the package.
const char* module_of(const std::string& command) {
  if (command == "animate") return "nonholo._animation";
  if (command == "view") return "nonholo._viewer";
  return nullptr;
}

#ifdef NONHOLO_PYTHON_EXECUTABLE
// Where the package may be, in order: NONHOLO_PYTHONPATH; python/ beside this executable (a
// build tree, also when copied or moved: it was looked for at the configured build path only);
// the build tree this executable was configured in; the installed one.
std::vector<std::string> package_candidates() {
  if (const char* forced = std::getenv("NONHOLO_PYTHONPATH")) return {forced};
  char self[4096];
  const ssize_t n = readlink("/proc/self/exe", self, sizeof(self) - 1);
  const std::string exe = n > 0 ? std::string(self, static_cast<std::size_t>(n)) : std::string();
  std::vector<std::string> out;
  if (const auto slash = exe.rfind('/'); slash != std::string::npos) out.push_back(exe.substr(0, slash) + "/python");
  out.push_back(std::string(NONHOLO_BUILD_DIR) + "/python");
  out.push_back(NONHOLO_PYTHON_INSTALLED_DIR);
  return out;
}

// The first candidate that holds the package (nonholo/__init__.py); "" when none does.
std::string package_dir(const std::vector<std::string>& candidates) {
  for (const std::string& dir : candidates)
    if (::access((dir + "/nonholo/__init__.py").c_str(), R_OK) == 0) return dir;
  return "";
}
#endif

}  // namespace

bool run_python_command(int argc, const char* const* argv, int* exit_code) {
  if (argc < 2) return false;
  const char* module = module_of(argv[1]);
  if (!module) return false;
#ifndef NONHOLO_PYTHON_EXECUTABLE
  std::cerr << "nonholo " << argv[1] << ": this nonholo was built without its Python package "
            << "(CMake option NONHOLO_BUILD_PYTHON; Debian: pybind11-dev python3-dev python3-numpy)" << std::endl;
  *exit_code = 1;
  return true;
#else
  const std::string python = NONHOLO_PYTHON_EXECUTABLE;
  std::vector<std::string> args{python, "-m", module};
  for (int i = 2; i < argc; ++i) args.emplace_back(argv[i]);
  std::vector<char*> child_argv;
  for (std::string& a : args) child_argv.push_back(a.data());
  child_argv.push_back(nullptr);

  const std::vector<std::string> candidates = package_candidates();
  const std::string dir = package_dir(candidates);
  if (dir.empty()) {  // python3 would say only "No module named 'nonholo'"
    std::cerr << "nonholo " << argv[1] << ": cannot find nonholo's Python package (nonholo/__init__.py); looked in";
    for (const std::string& c : candidates) std::cerr << " " << c;
    std::cerr << ": run the nonholo of a build tree (python/ beside it), install nonholo (cmake --install), or set "
                 "NONHOLO_PYTHONPATH to the folder that holds nonholo/"
              << std::endl;
    *exit_code = 1;
    return true;
  }
  const char* old = std::getenv("PYTHONPATH");
  const std::string path = dir + (old && *old ? std::string(":") + old : std::string());
  setenv("PYTHONPATH", path.c_str(), 1);
  setenv("NONHOLO_COMMAND_NAME", (std::string("nonholo ") + argv[1]).c_str(), 1);  // for its usage line

  pid_t pid = 0;
  if (const int e = posix_spawn(&pid, python.c_str(), nullptr, nullptr, child_argv.data(), environ)) {
    std::cerr << "nonholo " << argv[1] << ": cannot start " << python << ": " << std::strerror(e) << std::endl;
    *exit_code = 1;
    return true;
  }
  int status = 0;
  while (waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  *exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  return true;
#endif
}

}  // namespace nonholo::scenarios
