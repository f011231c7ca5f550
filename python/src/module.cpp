// nonholo._core: the C++ library as a Python module. bind_core.cpp holds the library's own API
// (bind_options.cpp, bind_model.cpp, bind_stepping.cpp: ModelBuilder, Model, Workspace, State,
// the step), bind_run.cpp the scenes and the
// command-line tool's run and batch; nonholo/__init__.py puts the friendly front on them.
#include <nonholo/build_config.hpp>
#include <nonholo/version.hpp>

#include <pybind11/pybind11.h>

#include "bindings.hpp"

PYBIND11_MODULE(_core, m) {
  m.doc() = "nonholo: momentum- and energy-preserving integrators for nonholonomic systems (C++ core)";
  m.attr("__version__") = nonholo::kVersion;
  m.attr("__git_revision__") = nonholo::kGitRevision;
  m.attr("__target_arch__") = nonholo::kTargetArch;  // "portable" or "-march=..." (CMake NONHOLO_ARCH)
  nonholo::python::bind_core(m);
  nonholo::python::bind_run(m);
}
