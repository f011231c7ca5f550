// The library's API in Python (bind_core): the parts bound in order by bind_options.cpp,
// bind_model.cpp and bind_stepping.cpp. Set-up errors (std::invalid_argument) arrive as
// ValueError with the library's message (pybind11's own translation); a step never raises: it
// returns a Status and Workspace.message says why. Python callables become the model's
// callbacks (callbacks.hpp).
#include "bind_common.hpp"
#include "bindings.hpp"

namespace nonholo::python {

void bind_core(py::module_& m) {
  // A callback's exception leaving a set-up call (start, diagnose): the callable's own
  // exception again, or ValueError for a result of the wrong kind or size.
  py::register_local_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const CallbackError& e) {
      if (e.original) {
        py::error_already_set original = *e.original;
        original.restore();
      } else {
        PyErr_SetString(PyExc_ValueError, e.what());
      }
    }
  });
  bind_status(m);
  bind_options(m);
  bind_model(m);  // before the builder: build()'s signature names Model, not the C++ type
  bind_builder(m);
  bind_state(m);
  bind_stepping(m);
  bind_quaternions(m);
}

}  // namespace nonholo::python
