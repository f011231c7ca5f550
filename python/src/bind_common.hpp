#pragma once
// What the bind_*.cpp files share: the Python-side model and builder (with whether they call
// Python), the conversions and checks of arrays, and the parts of the module each file binds.
#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/stl.h>

#include <nonholo/nonholo.hpp>

#include <algorithm>
#include <cctype>
#include <limits>
#include <sstream>
#include <string>

#include "callbacks.hpp"

namespace nonholo::python {
namespace py = pybind11;

using Array = py::array_t<double, py::array::c_style | py::array::forcecast>;

// A built model and whether it calls Python (see above).
struct PyModel {
  Model model;
  bool calls_python = false;
};

struct PyBuilder {
  ModelBuilder builder;
  bool calls_python = false;
};

// A fresh read-only copy: writing into `state.q[0]` would otherwise change a copy silently.
inline py::array_t<double> frozen(const Vector& v) {
  py::array_t<double> a(v.size(), v.data());
  py::detail::array_proxy(a.ptr())->flags &= ~py::detail::npy_api::NPY_ARRAY_WRITEABLE_;
  return a;
}

// Python's shortest round-trip form of a float, for the reprs.
inline std::string num(double x) { return py::repr(py::float_(x)); }

inline void assign(Vector& to, const Array& from, const char* what) {
  if (from.ndim() != 1 || from.size() != to.size()) {
    std::ostringstream os;
    os << "State." << what << ": expected a 1-D array of " << to.size() << " values, got " << from.size()
       << " in " << from.ndim() << " dimension(s)";
    throw py::value_error(os.str());
  }
  std::copy(from.data(), from.data() + from.size(), to.data());
}

// The pairings C++ leaves to the caller: a workspace keeps a pointer to its model, a state
// must have its model's sizes (step() reports both as a status; the others would read past
// the vectors).
inline void check_pair(const PyModel& m, const Workspace& ws) {
  if (&ws.model() != &m.model) throw py::value_error("the workspace was built for another model");
}
// q has n_q entries, p and force n_v (the same unless the model has 3-D rigid bodies).
inline void check_state(const PyModel& m, const State& s) {
  const Eigen::Index nq = m.model.num_configuration(), n = m.model.num_velocities(), r = m.model.num_one_forms();
  if (s.q.size() != nq || s.p.size() != n || s.force.size() != n || s.lambda.size() != r)
    throw py::value_error("the state does not have the model's sizes (" +
                          (nq == n ? std::to_string(n) + " coordinates, "
                                   : std::to_string(nq) + " configuration entries, " + std::to_string(n) +
                                         " velocities, ") +
                          std::to_string(r) + " one-forms): start it for this model");
}

// A 3-vector from any sequence of 3 numbers; ValueError naming `what` otherwise.
inline Eigen::Vector3d vector3(const py::object& v, const std::string& what) {
  auto a = Array::ensure(v);
  if (!a) {
    PyErr_Clear();
    throw py::value_error(what + ": expected 3 numbers, got " + callback_detail::type_name(v));
  }
  if (a.ndim() != 1 || a.size() != 3)
    throw py::value_error(what + ": expected 3 numbers, got an array of " + std::to_string(a.size()) + " in " +
                          std::to_string(a.ndim()) + " dimension(s)");
  return {a.data()[0], a.data()[1], a.data()[2]};
}

// The parts of the module, in the order bind_core (bind_core.cpp) registers them.
void bind_status(py::module_& m);       // bind_options.cpp
void bind_options(py::module_& m);      // bind_options.cpp
void bind_model(py::module_& m);        // bind_model.cpp
void bind_builder(py::module_& m);      // bind_model.cpp
void bind_state(py::module_& m);        // bind_stepping.cpp
void bind_stepping(py::module_& m);     // bind_stepping.cpp
void bind_quaternions(py::module_& m);  // bind_model.cpp

}  // namespace nonholo::python
