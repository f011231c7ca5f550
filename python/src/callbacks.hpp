#pragma once
// Python callables as the library's callbacks (nonholo/types.hpp, elements.hpp). Each call
// takes the GIL (a step may run with it released), hands the callable copies of the vectors
// (the library swaps and reuses its buffers: a view kept by the callable would change under
// it) and checks the result's length. A Python exception or a bad result becomes a
// CallbackError naming the callback: a step turns it into Status::CallbackFailed with that text
// (core/src/base/callback_guard.hpp), a set-up call (start, diagnose) raises the original exception.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <nonholo/types.hpp>

#include <algorithm>
#include <functional>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>

namespace nonholo::python {

class CallbackError : public std::runtime_error {
 public:
  explicit CallbackError(const std::string& what) : std::runtime_error(what) {}
  CallbackError(const std::string& what, pybind11::error_already_set error)
      : std::runtime_error(what), original(std::move(error)) {}
  std::optional<pybind11::error_already_set> original;  // what the callable raised, if it raised
};

// Set when a callback was interrupted (Ctrl-C): the step fails with CallbackFailed, which the
// binding of step() then turns back into KeyboardInterrupt.
inline thread_local bool callback_interrupted = false;

// A Python callable shared by the copies of a std::function: copies need no GIL, and the last
// owner takes it to let go (a Model may be copied or dropped where the GIL is not held).
class Callable {
 public:
  explicit Callable(pybind11::object f) : f_(new pybind11::object(std::move(f)), drop) {}
  template <class... Args>
  pybind11::object operator()(Args&&... args) const {
    return (*f_)(std::forward<Args>(args)...);
  }

 private:
  static void drop(pybind11::object* f) {
    pybind11::gil_scoped_acquire gil;
    delete f;
  }
  std::shared_ptr<pybind11::object> f_;
};

namespace callback_detail {

inline pybind11::array_t<double> copy(ConstVecRef v) { return pybind11::array_t<double>(v.size(), v.data()); }

inline std::string type_name(const pybind11::handle& h) {
  return pybind11::str(pybind11::type::handle_of(h).attr("__name__"));
}

// "ValueError: message" (no traceback: it goes into one line of Workspace::message).
inline std::string describe(const pybind11::error_already_set& e) {
  try {
    const std::string text = pybind11::str(e.value());
    const std::string type = pybind11::str(e.type().attr("__name__"));
    return text.empty() ? type : type + ": " + text;
  } catch (...) {
    return "an exception that cannot be printed";
  }
}

// Runs call() with the GIL held; whatever goes wrong leaves as a CallbackError naming `name`.
template <class Call>
auto invoke(const char* name, Call&& call) {
  pybind11::gil_scoped_acquire gil;
  try {
    return call();
  } catch (pybind11::error_already_set& e) {
    if (e.matches(PyExc_KeyboardInterrupt)) callback_interrupted = true;
    throw CallbackError(std::string(name) + " raised " + describe(e), e);
  } catch (const pybind11::cast_error& e) {
    throw CallbackError(std::string(name) + ": " + e.what());
  }
}

// Copies the callable's result into out: any 1-D sequence of numbers of out's length.
inline void copy_result(const pybind11::object& r, VecRef out, const char* name, const char* expected) {
  namespace py = pybind11;
  auto wanted = [&] { return std::to_string(out.size()) + " values (" + expected + ")"; };  // on failure only
  if (r.is_none()) throw CallbackError(std::string(name) + " returned None, expected " + wanted());
  auto a = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(r);
  if (!a) {
    PyErr_Clear();
    throw CallbackError(std::string(name) + " returned " + type_name(r) + ", not an array of numbers");
  }
  if (a.ndim() != 1 || a.size() != out.size()) {
    std::string shape = "(";
    for (py::ssize_t i = 0; i < a.ndim(); ++i) shape += (i ? ", " : "") + std::to_string(a.shape(i));
    shape += a.ndim() == 1 ? ",)" : ")";
    throw CallbackError(std::string(name) + " returned an array of shape " + shape + ", expected " + wanted());
  }
  std::copy(a.data(), a.data() + a.size(), out.data());
}

inline double to_double(const pybind11::object& r, const char* name) {
  try {
    return r.cast<double>();
  } catch (const pybind11::cast_error&) {
    throw CallbackError(std::string(name) + " returned " + type_name(r) + ", not a number");
  }
}

}  // namespace callback_detail

// The callbacks, one per kind. `expected` says what the entries are, for the size message.
// f(q) -> a vector (one-form values, gaps, the potential's gradient).
inline std::function<void(ConstVecRef, VecRef)> vector_of_q(pybind11::object f, const char* name,
                                                           const char* expected) {
  return [c = Callable(std::move(f)), name, expected](ConstVecRef q, VecRef out) {
    callback_detail::invoke(name, [&] { callback_detail::copy_result(c(callback_detail::copy(q)), out, name, expected); });
  };
}

inline OneFormValues one_form_values_callback(pybind11::object f) {
  return vector_of_q(std::move(f), "one_form_values(q)",
                     "the one-form rows' entries, row by row in the order of their columns");
}

inline OneFormBias one_form_bias_callback(pybind11::object f) {
  return [c = Callable(std::move(f))](ConstVecRef q, ConstVecRef v, VecRef bias) {
    const char* name = "one_form_bias(q, qdot)";
    callback_detail::invoke(name, [&] {
      callback_detail::copy_result(c(callback_detail::copy(q), callback_detail::copy(v)), bias, name,
                                   "one per one-form row");
    });
  };
}

inline ConstraintGap gap_callback(pybind11::object f) {
  return vector_of_q(std::move(f), "gap(q)", "one per holonomic row, in declaration order");
}

inline Potential potential_callback(pybind11::object f) {
  return [c = Callable(std::move(f))](ConstVecRef q) {
    const char* name = "potential value(q)";
    return callback_detail::invoke(name, [&] { return callback_detail::to_double(c(callback_detail::copy(q)), name); });
  };
}

inline PotentialGradient gradient_callback(pybind11::object f) {
  return vector_of_q(std::move(f), "potential gradient(q)", "one per velocity coordinate");
}

inline ExternalForce force_callback(pybind11::object f) {
  return [c = Callable(std::move(f))](double t, ConstVecRef q, VecRef force) {
    const char* name = "external_force(t, q)";
    callback_detail::invoke(name, [&] {
      callback_detail::copy_result(c(t, callback_detail::copy(q)), force, name, "one per velocity coordinate");
    });
  };
}

inline MomentumMap momentum_map_callback(const std::string& map, pybind11::object f) {
  return [c = Callable(std::move(f)), name = "momentum_map '" + map + "'(q, p)"](ConstVecRef q, ConstVecRef p) {
    return callback_detail::invoke(name.c_str(), [&] {
      return callback_detail::to_double(c(callback_detail::copy(q), callback_detail::copy(p)), name.c_str());
    });
  };
}

// xi(q) of a symmetry (ModelBuilder.symmetry): n_v entries, in the constraint distribution.
inline SymmetryGenerator generator_callback(const std::string& symmetry, pybind11::object f) {
  return [c = Callable(std::move(f)), name = "symmetry '" + symmetry + "' generator(q)"](ConstVecRef q, VecRef xi) {
    callback_detail::invoke(name.c_str(), [&] {
      callback_detail::copy_result(c(callback_detail::copy(q)), xi, name.c_str(),
                                   "one per velocity coordinate: a rigid body's Omega, then its centre's velocity");
    });
  };
}

// xi(q) of a symmetry local to one body (ModelBuilder.symmetry's body=): f returns the body's
// `count` velocity entries, written at `first`; or all n_v entries, which must be zero outside
// the body (the restarts read the body's entries alone: a nonzero elsewhere would be dropped).
inline SymmetryGenerator local_generator_callback(const std::string& symmetry, pybind11::object f, int body,
                                                  int first, int count) {
  const std::string expected = "body " + std::to_string(body) + "'s velocity entries " + std::to_string(first) +
                               ".." + std::to_string(first + count - 1) + ", or all n_v with zeros elsewhere";
  return [c = Callable(std::move(f)), name = "symmetry '" + symmetry + "' generator(q)", expected, body, first,
          count](ConstVecRef q, VecRef xi) {
    namespace py = pybind11;
    callback_detail::invoke(name.c_str(), [&] {
      const py::object r = c(callback_detail::copy(q));
      auto a = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(r);
      if (a && a.ndim() == 1 && a.size() == xi.size() && a.size() != count) {
        const double* x = a.data();
        for (py::ssize_t i = 0; i < a.size(); ++i)
          if ((i < first || i >= first + count) && x[i] != 0.0)
            throw CallbackError(name + " returned " + std::to_string(x[i]) + " at entry " + std::to_string(i) +
                                ", outside body " + std::to_string(body) + " (a symmetry local to body " +
                                std::to_string(body) + " is zero elsewhere)");
        std::copy(x + first, x + first + count, xi.data() + first);
        return;
      }
      if (!a) PyErr_Clear();
      callback_detail::copy_result(r, xi.segment(first, count), name.c_str(), expected.c_str());
    });
  };
}

// f(t) -> 3 numbers (a rigid body's torque or force, elements.hpp's TimeVector).
inline std::function<Eigen::Vector3d(double)> time_vector_callback(const std::string& name, const char* expected,
                                                                   pybind11::object f) {
  return [c = Callable(std::move(f)), name, expected](double t) {
    Eigen::Vector3d out;
    callback_detail::invoke(name.c_str(), [&] { callback_detail::copy_result(c(t), out, name.c_str(), expected); });
    return out;
  };
}

inline std::function<double(double)> time_callback(const std::string& name, pybind11::object f) {
  return [c = Callable(std::move(f)), name](double t) {
    return callback_detail::invoke(name.c_str(), [&] { return callback_detail::to_double(c(t), name.c_str()); });
  };
}

}  // namespace nonholo::python
