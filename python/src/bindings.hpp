#pragma once
// The two halves of the module (module.cpp).
#include <pybind11/pybind11.h>

namespace nonholo::python {

void bind_core(pybind11::module_& m);  // bind_core.cpp: the library's API
void bind_run(pybind11::module_& m);   // bind_run.cpp: scenes, run, batch

}  // namespace nonholo::python
