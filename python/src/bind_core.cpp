// The library's API in Python: ModelBuilder, Model, Workspace, RattleOptions, State, starts,
// step, diagnose. Set-up errors (std::invalid_argument) arrive as ValueError with the library's
// message (pybind11's own translation); a step never raises: it returns a Status and
// Workspace.message says why. Python callables become the model's callbacks (callbacks.hpp).
//
// The GIL: a model records whether any of its callbacks is Python (Model.calls_python). The
// step, the multi-step loop and diagnose release the GIL for a model that never calls Python;
// with Python callbacks they keep it (each callback would otherwise take it back, at a cost per
// call). The callbacks take it anyway (callbacks.hpp), so a release is never unsafe.
#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/stl.h>

#include <nonholo/nonholo.hpp>
#include <nonholo/scenarios/scene.hpp>
#include <nonholo/scenarios/scene_file.hpp>
#include <nonholo/sparse/factorization.hpp>

#include <cctype>
#include <chrono>
#include <limits>
#include <map>
#include <sstream>

#include "bindings.hpp"
#include "callbacks.hpp"

namespace nonholo::python {
namespace py = pybind11;

// A types.SimpleNamespace (build_scene's result), named so in the Python signature.
class SimpleNamespace : public py::object {
 public:
  explicit SimpleNamespace(py::object o) : py::object(std::move(o)) {}
};

}  // namespace nonholo::python

template <>
struct pybind11::detail::handle_type_name<nonholo::python::SimpleNamespace> {
  static constexpr auto name = const_name("types.SimpleNamespace");
};

namespace nonholo::python {
namespace {

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
py::array_t<double> frozen(const Vector& v) {
  py::array_t<double> a(v.size(), v.data());
  py::detail::array_proxy(a.ptr())->flags &= ~py::detail::npy_api::NPY_ARRAY_WRITEABLE_;
  return a;
}

// Python's shortest round-trip form of a float, for the reprs.
std::string num(double x) { return py::repr(py::float_(x)); }

void assign(Vector& to, const Array& from, const char* what) {
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
void check_pair(const PyModel& m, const Workspace& ws) {
  if (&ws.model() != &m.model) throw py::value_error("the workspace was built for another model");
}
// q has n_q entries, p and force n_v (the same unless the model has 3-D rigid bodies).
void check_state(const PyModel& m, const State& s) {
  const Eigen::Index nq = m.model.num_configuration(), n = m.model.num_velocities(), r = m.model.num_one_forms();
  if (s.q.size() != nq || s.p.size() != n || s.force.size() != n || s.lambda.size() != r)
    throw py::value_error("the state does not have the model's sizes (" +
                          (nq == n ? std::to_string(n) + " coordinates, "
                                   : std::to_string(nq) + " configuration entries, " + std::to_string(n) +
                                         " velocities, ") +
                          std::to_string(r) + " one-forms): start it for this model");
}

// A 3-vector from any sequence of 3 numbers; ValueError naming `what` otherwise.
Eigen::Vector3d vector3(const py::object& v, const std::string& what) {
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

// Runs f with the GIL released when the model calls no Python.
template <class F>
auto maybe_released(const PyModel& m, F&& f) {
  if (m.calls_python) return f();
  py::gil_scoped_release release;
  return f();
}

// A callback interrupted by Ctrl-C failed its step; give Python its KeyboardInterrupt back.
Status interrupted_or(Status status) {
  if (callback_interrupted && status == Status::CallbackFailed) {
    callback_interrupted = false;
    PyErr_SetNone(PyExc_KeyboardInterrupt);
    throw py::error_already_set();
  }
  return status;
}

Status one_step(const PyModel& m, Workspace& ws, State& s, const RattleOptions& o) {
  callback_interrupted = false;
  return interrupted_or(maybe_released(m, [&] { return step(m.model, ws, s, o); }));
}

// n steps, stopping at the first failure. Without the GIL (for a model that calls no Python)
// it checks for Ctrl-C every 0.1 s and raises KeyboardInterrupt after the last whole step.
Status many_steps(const PyModel& m, Workspace& ws, State& s, const RattleOptions& o, long n) {
  if (n < 0) throw py::value_error("steps: n = " + std::to_string(n) + " must not be negative");
  callback_interrupted = false;
  if (m.calls_python) {
    for (long k = 0; k < n; ++k)
      if (const Status status = interrupted_or(step(m.model, ws, s, o)); status != Status::Ok) return status;
    return Status::Ok;
  }
  Status status = Status::Ok;
  bool interrupted = false;
  {
    py::gil_scoped_release release;
    using Clock = std::chrono::steady_clock;
    auto last = Clock::now();
    for (long k = 0; k < n && status == Status::Ok && !interrupted; ++k) {
      status = step(m.model, ws, s, o);
      if (const auto now = Clock::now(); now - last > std::chrono::milliseconds(100)) {
        last = now;
        py::gil_scoped_acquire gil;
        interrupted = PyErr_CheckSignals() != 0;  // leaves the exception set for below
      }
    }
  }
  if (interrupted) throw py::error_already_set();
  return status;
}

void bind_status(py::module_& m) {
  py::enum_<Status> e(m, "Status", "What a step reports (core/include/nonholo/status.hpp); Status.Ok on success.");
  // Named as in C++, from the library's names ("callback-failed" -> CallbackFailed), up to the
  // last enumerator (kLastStatus).
  for (int i = 0; i <= static_cast<int>(kLastStatus); ++i) {
    const auto s = static_cast<Status>(i);
    std::string name;
    bool upper = true;
    for (const char* c = to_string(s); *c; ++c) {
      if (*c == '-') {
        upper = true;
        continue;
      }
      name += upper ? static_cast<char>(std::toupper(static_cast<unsigned char>(*c))) : *c;
      upper = false;
    }
    e.value(name.c_str(), s);
  }
  // pybind11's own `value` has no docstring: the same property again, documented.
  e.def_property_readonly("value", [](Status s) { return static_cast<int>(s); },
                          "The enumerator's integer value, as in C++ (Status.Ok is 0).");
  e.def_property_readonly("text", [](Status s) { return to_string(s); },
                          "The library's name for it, as the command line prints it: 'ok', 'callback-failed', ...");
}

void bind_options(py::module_& m) {
  const RattleOptions d;
  py::class_<RattleOptions> c(m, "RattleOptions", R"(Options of the explicit step (core/include/nonholo/rattle_options.hpp).

All but h are keyword arguments. Invalid values raise ValueError with the library's message,
in the constructor and on assignment to an attribute (an assignment is checked together with
the other fields, so set `order` before a `composition` of that order). hitch is 'holonomic'
or 'oneform'; restart is 'auto', '0' (never) or a number of steps K; composition is 'auto',
'triple-jump', 'suzuki5', 'blanes-moan4' (order 4), 'yoshida7', 'kahan-li9', 'blanes-moan6'
(order 6), 'mclachlan15' or 'kahan-li17' (order 8); rotation (models with 3-D
rigid bodies: the rotation's discrete Lagrangian) is 'moser-veselov', 'moser-veselov-f' or
'exponential'.)");
  c.def(py::init([](double h, double min_pivot_ratio, const std::string& hitch, double gap_tolerance,
                    double gap_tolerance_limit, int max_gap_iterations, const std::string& restart,
                    double restart_tolerance, int monitor_every, int order, const std::string& composition,
                    const std::string& rotation) {
          RattleOptions o;
          o.h = h;
          o.min_pivot_ratio = min_pivot_ratio;
          o.hitch = hitch_mode_from_string(hitch);
          o.gap_tolerance = gap_tolerance;
          o.gap_tolerance_limit = gap_tolerance_limit;
          o.max_gap_iterations = max_gap_iterations;
          set_restart(o.restart, restart);
          o.restart.tolerance = restart_tolerance;
          o.restart.monitor_every = monitor_every;
          o.order = order;
          o.composition = composition_from_string(composition);
          o.rotation = rotation_from_string(rotation);
          validate(o);
          return o;
        }),
        py::arg("h") = d.h, py::kw_only(), py::arg("min_pivot_ratio") = d.min_pivot_ratio,
        py::arg("hitch") = to_string(d.hitch), py::arg("gap_tolerance") = d.gap_tolerance,
        py::arg("gap_tolerance_limit") = d.gap_tolerance_limit, py::arg("max_gap_iterations") = d.max_gap_iterations,
        py::arg("restart") = restart_spec(d.restart), py::arg("restart_tolerance") = d.restart.tolerance,
        py::arg("monitor_every") = d.restart.monitor_every, py::arg("order") = d.order,
        py::arg("composition") = to_string(d.composition), py::arg("rotation") = to_string(d.rotation));

  // A validated attribute: changed on a copy, checked whole, then kept.
  auto field = [&c](const char* name, auto get, auto set, const char* doc) {
    using T = decltype(get(std::declval<const RattleOptions&>()));
    c.def_property(name, get, [set](RattleOptions& o, T value) {
      RattleOptions changed = o;
      set(changed, value);
      validate(changed);
      o = changed;
    }, doc);
  };
  field("h", [](const RattleOptions& o) { return o.h; }, [](RattleOptions& o, double v) { o.h = v; },
        "The time step (with order 4, 6 or 8, the composed step's size H).");
  field("min_pivot_ratio", [](const RattleOptions& o) { return o.min_pivot_ratio; },
        [](RattleOptions& o, double v) { o.min_pivot_ratio = v; },
        "The smallest accepted pivot of C relative to its diagonal (the squared sine of the angle "
        "between a one-form and the span of the others); below it the step refuses "
        "(Status.NearlyDependentOneForms): nearly dependent one-forms would make lambda meaningless.");
  field("hitch", [](const RattleOptions& o) { return std::string(to_string(o.hitch)); },
        [](RattleOptions& o, const std::string& v) { o.hitch = hitch_mode_from_string(v); },
        "How the holonomic rows (hitches) are treated: 'holonomic' (g(q_{k+1}) = 0 enforced at position "
        "level, as RATTLE does) or 'oneform' (plain one-forms, the paper's method).");
  field("gap_tolerance", [](const RattleOptions& o) { return o.gap_tolerance; },
        [](RattleOptions& o, double v) { o.gap_tolerance = v; },
        "Holonomic mode (hitch 'holonomic'): the position-level corrections iterate until "
        "max ``|g_j(q_{k+1})|`` <= gap_tolerance (raised to 16 eps max ``|q|`` when round-off alone exceeds it, up to "
        "gap_tolerance_limit).");
  field("gap_tolerance_limit", [](const RattleOptions& o) { return o.gap_tolerance_limit; },
        [](RattleOptions& o, double v) { o.gap_tolerance_limit = v; },
        "Holonomic mode (hitch 'holonomic'): the most gap_tolerance is raised to for large coordinates "
        "(at ``|q|`` ~ 1e19 round-off is 3e4); a step that cannot close the gaps to it fails with "
        "Status.GapNotConverged.");
  field("max_gap_iterations", [](const RattleOptions& o) { return o.max_gap_iterations; },
        [](RattleOptions& o, int v) { o.max_gap_iterations = v; },
        "Holonomic mode (hitch 'holonomic'): the position-level corrections a step may take before it "
        "fails with Status.GapNotConverged.");
  field("restart", [](const RattleOptions& o) { return restart_spec(o.restart); },
        [](RattleOptions& o, const std::string& v) { set_restart(o.restart, v); },
        "When the multipliers are restarted against the period-2 mode: 'auto' (when the measured "
        "parasitic amplitude exceeds restart_tolerance), '0' (never: the paper's plain method) or a "
        "whole number K (every K steps).");
  field("restart_tolerance", [](const RattleOptions& o) { return o.restart.tolerance; },
        [](RattleOptions& o, double v) { o.restart.tolerance = v; },
        "restart 'auto': restart when the parasitic amplitude (h/2) "
        "``|lambda~ - lambda_s|_C / |p~|_{M^-1}`` (dimensionless) exceeds this; 0: h^3 (h in the "
        "model's time unit, never below the amplitude's round-off), 1e-3 from h = 0.1 on.");
  field("monitor_every", [](const RattleOptions& o) { return o.restart.monitor_every; },
        [](RattleOptions& o, int v) { o.restart.monitor_every = v; },
        "Measure the parasitic amplitude at least every this many steps, in every restart mode "
        "(0: never; restart 'auto' needs at least 1).");
  field("order", [](const RattleOptions& o) { return o.order; }, [](RattleOptions& o, int v) { o.order = v; },
        "2 (the plain step of size h), or 4, 6 or 8: one step advances by h through a palindromic "
        "composition of plain substeps (see composition).");
  field("composition", [](const RattleOptions& o) { return std::string(to_string(o.composition)); },
        [](RattleOptions& o, const std::string& v) { o.composition = composition_from_string(v); },
        "The composition of orders 4, 6 and 8 (names in the class's text); 'auto': blanes-moan4, "
        "blanes-moan6 or kahan-li17 for the order (none for order 2).");
  field("rotation", [](const RattleOptions& o) { return std::string(to_string(o.rotation)); },
        [](RattleOptions& o, const std::string& v) { o.rotation = rotation_from_string(v); },
        "Models with 3-D rigid bodies: the rotation's discrete Lagrangian, 'moser-veselov' (energy exact "
        "for any inertia), 'moser-veselov-f' (also exact on an isotropic body's free rotation) or "
        "'exponential' (for comparison: its energy drifts for a non-isotropic body).");
  c.def("__repr__", [](const RattleOptions& o) {
    std::ostringstream os;
    os << "RattleOptions(h=" << num(o.h) << ", min_pivot_ratio=" << num(o.min_pivot_ratio) << ", hitch='"
       << to_string(o.hitch) << "', gap_tolerance=" << num(o.gap_tolerance)
       << ", gap_tolerance_limit=" << num(o.gap_tolerance_limit) << ", max_gap_iterations=" << o.max_gap_iterations
       << ", restart='" << restart_spec(o.restart) << "', restart_tolerance=" << num(o.restart.tolerance)
       << ", monitor_every=" << o.restart.monitor_every << ", order=" << o.order << ", composition='"
       << to_string(o.composition) << "', rotation='" << to_string(o.rotation) << "')";
    return os.str();
  });
}

// A Python callable for the builder, which from now on makes models that call Python.
py::object callable(PyBuilder& b, py::object f) {
  if (!PyCallable_Check(f.ptr())) throw py::type_error("expected a callable, got " + callback_detail::type_name(f));
  b.calls_python = true;
  return f;
}

// A thrust's force or torque: None, a number (no Python at step time) or a callable of t.
TimeFunction time_function(PyBuilder& b, const py::object& f, const char* name) {
  if (f.is_none()) return {};
  if (!PyCallable_Check(f.ptr())) {
    try {
      return [value = f.cast<double>()](double) { return value; };
    } catch (const py::cast_error&) {
      throw py::type_error(std::string("add_thrust: ") + name + " must be None, a number or a callable of t, got " +
                           callback_detail::type_name(f));
    }
  }
  return time_callback(std::string("thrust ") + name + "(t)", callable(b, f));
}

// A rigid body's inertia: a 3x3 matrix, its 3 principal moments (a diagonal inertia) or one
// number J (the isotropic J Id). The builder checks the values (SPD, conditioning).
Eigen::Matrix3d inertia_of(const py::object& inertia) {
  auto a = Array::ensure(inertia);
  if (!a) {
    PyErr_Clear();
    throw py::value_error("add_rigid_body: inertia must be a 3x3 matrix, 3 principal moments or one number, got " +
                          callback_detail::type_name(inertia));
  }
  const double* x = a.data();
  if (a.ndim() == 0) return x[0] * Eigen::Matrix3d::Identity();
  if (a.ndim() == 1 && a.size() == 3) return Eigen::Vector3d(x[0], x[1], x[2]).asDiagonal();
  if (a.ndim() == 2 && a.shape(0) == 3 && a.shape(1) == 3)
    return Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(x);
  std::string shape = "(";
  for (py::ssize_t i = 0; i < a.ndim(); ++i) shape += (i ? ", " : "") + std::to_string(a.shape(i));
  shape += a.ndim() == 1 ? ",)" : ")";
  throw py::value_error("add_rigid_body: inertia must be a 3x3 matrix, 3 principal moments or one number, got an "
                        "array of shape " + shape);
}

// A body torque's or force's function: a callable of t returning 3 numbers, or 3 numbers (a
// constant: no Python at step time).
TimeVector time_vector(PyBuilder& b, const py::object& f, const char* element, const char* what, int body,
                       const char* expected) {
  if (f.is_none())
    throw py::type_error(std::string("add_") + element + ": " + what +
                         " must be a callable of t or 3 numbers, got None");
  if (!PyCallable_Check(f.ptr())) {
    const Eigen::Vector3d value = vector3(f, std::string("add_") + element + ": " + what);
    return [value](double) { return value; };
  }
  return time_vector_callback(std::string(what) + "(t) of body " + std::to_string(body), expected, callable(b, f));
}

// Runs add(); a call the builder refuses leaves calls_python as it was (its callable is not kept).
template <class Add>
void unless_refused(PyBuilder& b, Add&& add) {
  const bool before = b.calls_python;
  try {
    add();
  } catch (...) {
    b.calls_python = before;
    throw;
  }
}

void bind_builder(py::module_& m) {
  py::class_<PyBuilder>(m, "ModelBuilder", R"(Builds a Model, validating everything it is given (ValueError names the body,
row or column at fault). Callbacks are Python callables given copies of q (and qdot, p) as
1-D float64 arrays; those filling a vector return a 1-D array (or sequence) of its length.
Rows from add_one_form cannot be mixed with element rows (add_knife_edge, add_hitch, the
rigid-body constraints). With 3-D rigid bodies (add_rigid_body) q has n_q entries and every
vector in velocity space (rows' columns, gradients, forces, generators) n_v (Model.num_velocities).)")
      .def(py::init<>())
      .def("add_body", [](PyBuilder& b, const std::vector<std::string>& names, const Eigen::MatrixXd& mass_block) {
            return b.builder.add_body(names, mass_block);
          }, py::arg("names"), py::arg("mass_block"),
          "A body with one coordinate per name and a constant SPD mass block; returns its index.")
      .def("add_planar_body", [](PyBuilder& b, const std::vector<std::string>& names, double mass, double inertia) {
            if (names.size() != 3)
              throw py::value_error("add_planar_body: expected 3 coordinate names (x, y, theta), got " +
                                    std::to_string(names.size()));
            return b.builder.add_planar_body({names[0], names[1], names[2]}, mass, inertia);
          }, py::arg("names"), py::arg("mass"), py::arg("inertia"),
          "A planar rigid body (x, y, theta of its centre of mass), M = diag(m, m, I); returns its index.")
      .def("add_rigid_body", [](PyBuilder& b, double mass, const py::object& inertia, int translation,
                                std::string name) {
            RigidBody body;
            body.mass = mass;
            body.inertia = inertia_of(inertia);
            body.translation = translation;
            body.name = std::move(name);
            return b.builder.add_rigid_body(body);
          }, py::arg("mass") = 1.0, py::arg("inertia") = 1.0,
          py::arg("translation") = 0, py::arg("name") = "",
          R"(A 3-D rigid body (core/include/nonholo/rigid_body.hpp); returns its index. Its configuration
is a unit quaternion (w, x, y, z) and the position of its centre in R^d, d = translation: 0 (a
fixed point), 2 (the centre moves in a horizontal plane) or 3 (free); its velocities are the
body-frame angular velocity Omega, then the centre's velocity. inertia: the central inertia in
the body frame, a 3x3 SPD matrix, its 3 principal moments or one number J (J Id). Coordinates
are named qw<name>, qx<name>, ..., x<name>; velocities wx<name>, ..., vx<name> (name: the
body's index when empty).)")
      .def("reserve", [](PyBuilder& b, int bodies, int coordinates, int rows, int values) {
            b.builder.reserve(bodies, coordinates, rows, values);
          }, py::arg("bodies"), py::arg("coordinates"), py::arg("rows"), py::arg("values"),
          R"(Optional: room for a model of this size (bodies, coordinates, rows of mu and their nonzero
values), so that a million bodies are added without regrowing the builder's arrays.)")
      .def("add_one_form", [](PyBuilder& b, const std::vector<int>& columns, std::string label) {
            return b.builder.add_one_form(columns, std::move(label));
          }, py::arg("columns"), py::arg("label") = "",
          "A constraint row mu_a(q) qdot = 0 on these columns (its fixed pattern); returns the row index.")
      .def("add_holonomic_row", [](PyBuilder& b, const std::vector<int>& columns, std::string label) {
            return b.builder.add_holonomic_row(columns, std::move(label));
          }, py::arg("columns"), py::arg("label") = "",
          "A row that is the gradient of a holonomic constraint g_j(q) = 0 (give its g with gap()).")
      .def("one_form_values", [](PyBuilder& b, py::object f) {
            b.builder.one_form_values(one_form_values_callback(callable(b, std::move(f))));
          }, py::arg("values"),
          "values(q) -> the rows' entries, row by row in the order of each row's columns (nnz values).")
      .def("one_form_bias", [](PyBuilder& b, py::object f) {
            b.builder.one_form_bias(one_form_bias_callback(callable(b, std::move(f))));
          }, py::arg("bias"), "bias(q, qdot) -> (d/dt mu(q)) qdot, one value per row (optional).")
      .def("gap", [](PyBuilder& b, py::object f) { b.builder.gap(gap_callback(callable(b, std::move(f)))); },
          py::arg("gap"), "gap(q) -> g(q), one value per holonomic row in declaration order.")
      .def("potential", [](PyBuilder& b, py::object value, py::object gradient) {
            b.builder.potential(potential_callback(callable(b, std::move(value))),
                                gradient_callback(callable(b, std::move(gradient))));
          }, py::arg("value"), py::arg("gradient"), "value(q) -> V (a float), gradient(q) -> dV/dq (n values).")
      .def("external_force", [](PyBuilder& b, py::object f) {
            b.builder.external_force(force_callback(callable(b, std::move(f))));
          }, py::arg("force"), "force(t, q) -> F(t, q), n values.")
      .def("momentum_map", [](PyBuilder& b, const std::string& name, py::object f) {
            b.builder.momentum_map(name, momentum_map_callback(name, callable(b, std::move(f))));
          }, py::arg("name"), py::arg("map"), "map(q, p) -> J (a float), linear in p.")
      .def("add_knife_edge", [](PyBuilder& b, int body, double a, std::string label) {
            return b.builder.add_knife_edge({body, a}, std::move(label));
          }, py::arg("body"), py::arg("a") = 0.0, py::arg("label") = "",
          "A blade at C - a e(theta) of a planar body (one row); returns the row index.")
      .def("add_hitch", [](PyBuilder& b, int rear, int front, double d, double f, std::string label) {
            return b.builder.add_hitch({rear, front, d, f}, std::move(label));
          }, py::arg("rear"), py::arg("front"), py::arg("d"), py::arg("f"), py::arg("label") = "",
          "Holds C_r - d e(theta_r) on C_f + f e(theta_f) (two holonomic rows); returns the first row's index.")
      .def("add_torsional_spring", [](PyBuilder& b, int first, int second, double k, double rest) {
            b.builder.add_torsional_spring({first, second, k, rest});
          }, py::arg("first"), py::arg("second"), py::arg("k"), py::arg("rest") = 0.0,
          "V = (k/2)(theta_first - theta_second - rest)^2.")
      .def("add_thrust", [](PyBuilder& b, int body, const py::object& force, const py::object& torque) {
            Thrust t{body, time_function(b, force, "force"), time_function(b, torque, "torque")};
            b.builder.add_thrust(std::move(t));
          }, py::arg("body"), py::arg("force") = py::none(), py::arg("torque") = py::none(),
          "force(t) along the body's heading and torque(t) on its angle: each None, a number or a callable of t.")
      .def("add_body_axis_constraint", [](PyBuilder& b, int body, const py::object& axis, std::string label) {
            return b.builder.add_body_axis_constraint({body, vector3(axis, "add_body_axis_constraint: axis")},
                                                      std::move(label));
          }, py::arg("body"), py::arg("axis") = py::make_tuple(0.0, 0.0, 1.0), py::arg("label") = "",
          "<Omega, a> = 0 with a fixed in the body (the Suslov problem): one row; returns its index.")
      .def("add_space_axis_constraint", [](PyBuilder& b, int body, const py::object& axis, std::string label) {
            return b.builder.add_space_axis_constraint({body, vector3(axis, "add_space_axis_constraint: axis")},
                                                       std::move(label));
          }, py::arg("body"), py::arg("axis") = py::make_tuple(0.0, 0.0, 1.0), py::arg("label") = "",
          "<Omega, R^T e> = 0 with e fixed in space (the Veselova problem): one row; returns its index.")
      .def("add_rolling_ball", [](PyBuilder& b, int body, double radius, std::string label) {
            return b.builder.add_rolling_ball({body, radius}, std::move(label));
          }, py::arg("body"), py::arg("radius") = 1.0, py::arg("label") = "",
          R"(A ball (centre of mass at its centre: the Chaplygin ball) rolling without slipping on z = 0:
two rows, and a holonomic height row with translation 3; returns the first row's index.)")
      .def("add_rolling_disk", [](PyBuilder& b, int body, double radius, std::string label) {
            return b.builder.add_rolling_disk({body, radius}, std::move(label));
          }, py::arg("body"), py::arg("radius") = 1.0, py::arg("label") = "",
          R"(A thin disk (its axis the body's e3) rolling without slipping on z = 0: three rows, the
vertical one holonomic; the body needs translation 3. Returns the first row's index.)")
      .def("add_rod", [](PyBuilder& b, int first, int second, double length, std::string label) {
            return b.builder.add_rod({first, second, length}, std::move(label));
          }, py::arg("first"), py::arg("second"), py::arg("length"), py::arg("label") = "",
          "A massless rod of this length between two bodies' centres (one holonomic row); returns its index.")
      .def("add_gravity", [](PyBuilder& b, double g) { b.builder.add_gravity(g); }, py::arg("g") = 9.81,
          "Gravity g along -e3 on every rigid body with translation 3 (an external force -m g e3).")
      .def("add_body_torque", [](PyBuilder& b, int body, const py::object& torque) {
            unless_refused(b, [&] {
              b.builder.add_body_torque(
                  {body, time_vector(b, torque, "body_torque", "body torque", body, "the torque in the body frame")});
            });
          }, py::arg("body"), py::arg("torque"),
          "torque(t) -> 3 numbers, the torque on a rigid body in its body frame (or 3 numbers: constant).")
      .def("add_body_force", [](PyBuilder& b, int body, const py::object& force) {
            unless_refused(b, [&] {
              b.builder.add_body_force(
                  {body, time_vector(b, force, "body_force", "body force", body, "the force on the centre, in space")});
            });
          }, py::arg("body"), py::arg("force"),
          R"(force(t) -> 3 numbers, the force on a rigid body's centre in space (or 3 numbers: constant);
a body moving in a plane ignores the vertical component.)")
      .def("symmetry", [](PyBuilder& b, const std::string& name, py::object generator) {
            b.builder.symmetry(name, generator_callback(name, callable(b, std::move(generator))));
          }, py::arg("name"), py::arg("generator"),
          R"(A horizontal symmetry by its generator xi(q) -> n_v values (velocity entries: a rigid body's
Omega in its body frame, then its centre's velocity), lying in the constraint distribution. Its
momentum map J = <xi(q), p> is added under `name`, and the restarts keep it exactly.)")
      .def_property_readonly("calls_python", [](const PyBuilder& b) { return b.calls_python; },
                             "True once a Python callable has been given to it; the models it builds then call Python.")
      .def("build", [](const PyBuilder& b) { return PyModel{b.builder.build(), b.calls_python}; },
          "The immutable Model (the builder can go on being used).");
}

void bind_model(py::module_& m) {
  py::class_<PyModel>(m, "Model", "An immutable model (ModelBuilder.build()).")
      .def_property_readonly("num_coordinates", [](const PyModel& p) { return p.model.num_coordinates(); },
                             "The velocity count n_v (its older name: every body was planar then, n_q = n_v).")
      .def_property_readonly("num_configuration", [](const PyModel& p) { return p.model.num_configuration(); },
                             "n_q, the size of q (n_v plus one per 3-D rigid body: a quaternion against Omega).")
      .def_property_readonly("num_velocities", [](const PyModel& p) { return p.model.num_velocities(); },
                             "n_v, the size of p, of forces, of a row of mu and of a symmetry's generator.")
      .def_property_readonly("num_bodies", [](const PyModel& p) { return p.model.num_bodies(); },
                             "The number of bodies, in the order added.")
      .def_property_readonly("num_one_forms", [](const PyModel& p) { return p.model.num_one_forms(); },
                             "m, the rows of mu (one-forms and holonomic rows): the size of State.lam.")
      .def_property_readonly("num_one_form_values", [](const PyModel& p) { return p.model.num_one_form_values(); },
                             "nnz(mu): the number of values one_form_values() returns.")
      .def_property_readonly("num_holonomic", [](const PyModel& p) { return p.model.num_holonomic(); },
                             "The number of holonomic constraints g(q) = 0 (hitches, rods, ...): one per holonomic "
                             "row.")
      .def_property_readonly("coordinate_names", [](const PyModel& p) { return p.model.coordinate_names(); },
                             "The names of the n_q entries of q.")
      .def_property_readonly("velocity_names", [](const PyModel& p) { return p.model.velocity_names(); },
                             "The names of the n_v velocity entries (coordinate_names unless there are rigid bodies).")
      .def_property_readonly("has_rigid_bodies", [](const PyModel& p) { return p.model.has_rigid_bodies(); },
                             "Whether the model has 3-D rigid bodies (ModelBuilder.add_rigid_body; then "
                             "n_q > n_v).")
      .def_property_readonly("holonomic_rows", [](const PyModel& p) { return p.model.holonomic_rows(); },
                             "The rows of mu that are gradients of holonomic constraints g(q) = 0, in "
                             "declaration order.")
      .def_property_readonly("momentum_map_names", [](const PyModel& p) {
        std::vector<std::string> names;
        for (const NamedMomentumMap& j : p.model.momentum_maps()) names.push_back(j.name);
        return names;
      }, "The names of the momentum maps and symmetries, in declaration order (that of momentum_maps()).")
      .def_property_readonly("has_analytic_bias", [](const PyModel& p) { return p.model.has_analytic_bias(); },
                             "Whether the model gives its bias (d/dt mu) qdot in closed form "
                             "(ModelBuilder.one_form_bias).")
      .def_property_readonly("has_potential", [](const PyModel& p) { return p.model.has_potential(); },
                             "Whether a potential V(q) is given.")
      .def_property_readonly("has_external_force", [](const PyModel& p) { return p.model.has_external_force(); },
                             "Whether an external force F(t, q) is given.")
      .def_property_readonly("has_elements", [](const PyModel& p) { return p.model.has_elements(); },
                             "Whether the model is built from constraint elements (add_knife_edge, add_hitch, the "
                             "rigid-body constraints, ...): its one-form values, bias, gaps, potential and forces "
                             "are then the elements' own.")
      .def_property_readonly("is_chain", [](const PyModel& p) { return p.model.is_chain(); },
                             "Whether the explicit step can stream the model body by body (a chain of elements): "
                             "backend 'auto' then chooses 'banded'.")
      .def_property_readonly("calls_python", [](const PyModel& p) { return p.calls_python; },
                             "True when a callback is Python; when false, step() and steps() release the GIL.")
      .def("body", [](const PyModel& p, int b) {
            if (b < 0 || b >= p.model.num_bodies()) throw py::index_error("body " + std::to_string(b) + " out of range");
            return py::make_tuple(p.model.body(b).offset, p.model.body(b).size);
          }, py::arg("b"), R"((first entry, number of entries) of body b in the velocities (p, forces, columns of mu);
the same as in q unless a 3-D rigid body comes first or it is one (body_configuration).)")
      .def("body_configuration", [](const PyModel& p, int b) {
            if (b < 0 || b >= p.model.num_bodies())
              throw py::index_error("body " + std::to_string(b) + " out of range");
            return py::make_tuple(p.model.body(b).q_offset, p.model.body(b).q_size);
          }, py::arg("b"), "(first entry, number of entries) of body b in the configuration q.")
      .def("mass_block", [](const PyModel& p, int b) {
            if (b < 0 || b >= p.model.num_bodies()) throw py::index_error("body " + std::to_string(b) + " out of range");
            const Body& body = p.model.body(b);
            Eigen::MatrixXd block(body.size, body.size);
            for (int i = 0; i < body.size; ++i)
              for (int j = 0; j < body.size; ++j) block(i, j) = p.model.mass().entry(body.offset + i, body.offset + j);
            return block;
          }, py::arg("b"), R"(Body b's constant mass block: its square block of M over the body's velocity entries
(model.body(b)); for a 3-D rigid body the inertia in the body frame, then m on the centre's velocity.)")
      .def("one_form_columns", [](const PyModel& p) {
            const sparse::RowPattern& pattern = p.model.one_form_pattern();
            std::vector<std::vector<int>> rows(static_cast<std::size_t>(pattern.rows));
            for (int r = 0; r < pattern.rows; ++r)
              rows[static_cast<std::size_t>(r)].assign(pattern.col_idx.begin() + pattern.row_ptr[r],
                                                       pattern.col_idx.begin() + pattern.row_ptr[r + 1]);
            return rows;
          }, "The columns of each one-form row (the pattern of one_form_values).")
      .def("one_form_values", [](const PyModel& p, const Vector& q) {
            if (q.size() != p.model.num_configuration())
              throw py::value_error("one_form_values: expected " + std::to_string(p.model.num_configuration()) +
                                    " coordinates, got " + std::to_string(q.size()));
            Vector mu = Vector::Zero(p.model.num_one_form_values());
            if (mu.size() > 0) p.model.one_form_values(q, mu);
            return mu;
          }, py::arg("q"), "mu(q)'s entries in pattern order.")
      .def("__repr__", [](const PyModel& p) {
        std::ostringstream os;
        os << "<nonholo.Model: " << p.model.num_bodies() << " bodies, " << p.model.num_configuration()
           << " coordinates, ";
        if (p.model.num_velocities() != p.model.num_configuration()) os << p.model.num_velocities() << " velocities, ";
        os << p.model.num_one_forms() << " one-forms>";
        return os.str();
      });
}

void bind_state(py::module_& m) {
  auto vector = [](Vector State::*field) {
    return [field](const State& s) { return frozen(s.*field); };
  };
  // q and p changed by hand: the energy a composed step restores is no longer the state's.
  auto set_vector = [](Vector State::*field, const char* name, bool reset_energy) {
    return [field, name, reset_energy](State& s, const Array& a) {
      assign(s.*field, a, name);
      if (reset_energy) s.target_energy = std::numeric_limits<double>::quiet_NaN();
    };
  };
  py::class_<State>(m, "State", R"(The integrator state (t_k, q_k, p~_k, lambda~_k, force_k), made by start_from_velocity or
start_from_two_points and advanced by step().

q, p, lam (the multipliers) and force are returned as fresh read-only float64 copies: a step
swaps the state's vectors with the workspace's buffers, so a view would change meaning under
it, and writing into a copy would be lost silently. Assigning a whole array (state.q = ...)
copies it in; it is then up to you to keep the state consistent (force = f + mu^T lam), and
setting q or p resets target_energy.)")
      .def_readonly("t", &State::t, "t_k = t0 + k h, the state's time (on its time grid, never summed step by step).")
      .def_property("q", vector(&State::q), set_vector(&State::q, "q", true),
                    "The configuration q_k (n_q entries; a rigid body's quaternion renormalised every step).")
      .def_property("p", vector(&State::p), set_vector(&State::p, "p", true),
                    "The average momentum p~_k (n_v entries), with mu(q_k) M^-1 p~_k = 0.")
      .def_property("lam", vector(&State::lambda), set_vector(&State::lambda, "lam", false),
                    "The multipliers lambda~_k, one per row of mu (sign convention M qdd = f + mu^T lambda).")
      .def_property("force", vector(&State::force), set_vector(&State::force, "force", false),
                    "f(t_k, q_k) + mu(q_k)^T lambda~_k (n_v entries): the total force of the next half kick.")
      .def_readonly("steps", &State::steps, "The steps taken since the start (restarts and measurements follow it).")
      .def_readonly("restarts", &State::restarts, "The multiplier restarts since the start (RattleOptions.restart).")
      .def_readwrite("target_energy", &State::target_energy,
                     R"(Composed steps (RattleOptions.order 4, 6 or 8) without external forces: the energy
(1/2) p~^T M^-1 p~ + V(q) every composed step restores. NaN until the first composed step sets it
from the state; setting q or p makes it NaN again.)")
      .def("post_momentum", [](const State& s, double h) { return frozen(s.post_momentum(h)); }, py::arg("h"),
           "p~ + (h/2) force: the momentum leaving t_k.")
      .def("pre_momentum", [](const State& s, double h) { return frozen(s.pre_momentum(h)); }, py::arg("h"),
           "p~ - (h/2) force: the momentum arriving at t_k.")
      .def("copy", [](const State& s) { return s; },
           "An independent copy of every field (as copy.copy and copy.deepcopy make).")
      .def("__copy__", [](const State& s) { return s; })
      .def("__deepcopy__", [](const State& s, const py::object&) { return s; })
      // Pickled whole (every field, the time grid and the restart schedule too), bit for bit: a
      // state saved and loaded steps on exactly as the original would.
      .def(py::pickle(
          [](const State& s) {
            const auto array = [](const Vector& v) { return py::array_t<double>(v.size(), v.data()); };
            return py::make_tuple(1, s.t, s.grid.t0, s.grid.h, s.grid.k, array(s.q), array(s.p), array(s.lambda),
                                  array(s.force), s.steps, s.restarts, s.watch.next_step, s.watch.last_step,
                                  s.watch.last_amplitude, s.watch.floor, s.target_energy);
          },
          [](const py::tuple& t) {
            if (t.size() != 16 || t[0].cast<int>() != 1)
              throw std::invalid_argument("State: not a pickled nonholo.State of this version");
            const auto vector = [](const py::handle& h) {
              const auto a = h.cast<py::array_t<double, py::array::c_style | py::array::forcecast>>();
              return Vector(Eigen::Map<const Vector>(a.data(), a.size()));
            };
            State s;
            s.t = t[1].cast<double>();
            s.grid.t0 = t[2].cast<double>();
            s.grid.h = t[3].cast<double>();
            s.grid.k = t[4].cast<long>();
            s.q = vector(t[5]);
            s.p = vector(t[6]);
            s.lambda = vector(t[7]);
            s.force = vector(t[8]);
            s.steps = t[9].cast<long>();
            s.restarts = t[10].cast<long>();
            s.watch.next_step = t[11].cast<long>();
            s.watch.last_step = t[12].cast<long>();
            s.watch.last_amplitude = t[13].cast<double>();
            s.watch.floor = t[14].cast<double>();
            s.target_energy = t[15].cast<double>();
            return s;
          }))
      .def("__repr__", [](const State& s) {
        std::ostringstream os;
        os << "<nonholo.State t=" << num(s.t) << ", steps=" << s.steps << ", " << s.q.size() << " coordinates>";
        return os.str();
      });
}

void bind_stepping(py::module_& m) {
  py::class_<Workspace>(m, "Workspace", R"(Every buffer and the factorisation one thread needs to integrate a model
(one Workspace per thread; it keeps its model alive). backend: 'auto', 'block-diagonal',
'dense', 'banded', 'cholmod-natural' or 'cholmod-amd'. message says why the last call failed.
One call at a time: see step().)")
      .def(py::init([](const PyModel& model, const std::string& backend, bool composed_steps, bool dla_steps) {
             WorkspaceOptions o;
             o.backend = sparse::backend_from_string(backend);
             o.composed_steps = composed_steps;
             o.dla_steps = dla_steps;
             return std::make_unique<Workspace>(model.model, o);
           }),
           py::arg("model"), py::arg("backend") = "auto", py::kw_only(), py::arg("composed_steps") = true,
           py::arg("dla_steps") = true, py::keep_alive<1, 2>())
      .def_property_readonly("message", [](const Workspace& ws) { return std::string(ws.message()); },
                             "Why the last failed call failed ('' if it did not).")
      .def_property_readonly("backend", [](const Workspace& ws) { return std::string(ws.backend_name()); },
                             "The factorisation of C in use ('auto' resolved: 'block-diagonal', 'dense', 'banded', "
                             "'cholmod-natural' or 'cholmod-amd'); 'none' for a model without one-forms.")
      .def_readonly("factorizations", &Workspace::factorizations,
                    "The numeric factorisations of C so far (the unit of cost the methods are compared in).")
      .def_readonly("parasitic", &Workspace::parasitic, "The parasitic amplitude the last step measured (NaN if none).")
      .def_readonly("restarted", &Workspace::restarted, "Whether the last step restarted the multipliers.")
      .def_readonly("gap_iterations", &Workspace::gap_iterations,
                    "The position-level iterations the last step took in holonomic mode (RattleOptions.hitch).")
      .def_readonly("legendre_iterations", &Workspace::legendre_iterations,
                    "The most Newton iterations a discrete Legendre transform has taken so far (rigid bodies; "
                    "0 for the closed forms).");

  m.def("start_from_velocity",
        [](const PyModel& model, Workspace& ws, double t0, const Vector& q0, const Vector& v0,
           const std::string& multiplier, double min_pivot_ratio) {
          check_pair(model, ws);
          StartOptions o;
          if (multiplier == "zero") o.multiplier = InitialMultiplier::Zero;
          else if (multiplier != "continuous")
            throw py::value_error("multiplier '" + multiplier + "': expected continuous or zero");
          o.min_pivot_ratio = min_pivot_ratio;
          return start_from_velocity(model.model, ws, t0, q0, v0, o);
        },
        py::arg("model"), py::arg("ws"), py::arg("t0"), py::arg("q0"), py::arg("v0"), py::kw_only(),
        py::arg("multiplier") = "continuous", py::arg("min_pivot_ratio") = StartOptions{}.min_pivot_ratio,
        R"(The state at (t0, q0) with the velocity guess v0 projected M-orthogonally onto D(q0). q0 has
n_q entries (a rigid body's quaternion of norm 1 within 1e-6, normalised here), v0 n_v (a rigid
body: Omega in its body frame, then its centre's velocity).)");
  m.def("start_from_two_points",
        [](const PyModel& model, Workspace& ws, double t0, const Vector& q0, const Vector& q1, double h,
           double tolerance, const std::string& rotation) {
          check_pair(model, ws);
          return start_from_two_points(model.model, ws, t0, q0, q1, h, tolerance, rotation_from_string(rotation));
        },
        py::arg("model"), py::arg("ws"), py::arg("t0"), py::arg("q0"), py::arg("q1"), py::arg("h"),
        py::arg("tolerance") = 1e-10, py::kw_only(), py::arg("rotation") = to_string(RattleOptions{}.rotation),
        R"(The paper's start from (q0, q1) in M0: the first step lands on q1. With rigid bodies the
post-momentum is the discrete Legendre transform of (q0, q1) for `rotation`: step with the same
RattleOptions.rotation.)");
  m.def("step", &one_step, py::arg("model"), py::arg("ws"), py::arg("state"), py::arg("options"),
        R"(One step. Returns a Status and never raises for a failed step: the state is then left as it
was and ws.message says why (a Python callback that raised gives Status.CallbackFailed with its
exception's text). Ctrl-C in a callback raises KeyboardInterrupt, the state unchanged. A workspace
serves one call at a time: a step while another runs on it (another thread, or a callback of
that step) returns Status.WorkspaceBusy and changes nothing; the starts and diagnose raise
ValueError('workspace-busy: ...').)");
  m.def("steps", &many_steps, py::arg("model"), py::arg("ws"), py::arg("state"), py::arg("options"), py::arg("n"),
        R"(Up to n steps, stopping at the first that fails (its Status is returned; state.steps counts
those taken). Runs without the GIL when the model calls no Python (Model.calls_python).)");

  py::class_<Diagnostics>(m, "Diagnostics", "What diagnose() measures (core/include/nonholo/diagnostics.hpp).")
      .def_readonly("energy", &Diagnostics::energy, "(1/2) p~ M^-1 p~ + V(q)")
      .def_readonly("energy_post", &Diagnostics::energy_post, "the energy of the post-momentum p_{k-1/2}")
      .def_readonly("residual", &Diagnostics::residual, "max ``|mu(q) M^-1 p~|``")
      .def_readonly("gap", &Diagnostics::gap, "max ``|g(q)|`` over the holonomic constraints")
      .def("__repr__", [](const Diagnostics& d) {
        std::ostringstream os;
        os << "Diagnostics(energy=" << num(d.energy) << ", energy_post=" << num(d.energy_post)
           << ", residual=" << num(d.residual) << ", gap=" << num(d.gap) << ")";
        return os.str();
      });
  m.def("diagnose",
        [](const PyModel& model, Workspace& ws, const State& s, double h) {
          check_pair(model, ws);
          check_state(model, s);
          return maybe_released(model, [&] { return diagnose(model.model, ws, s, h); });
        },
        py::arg("model"), py::arg("ws"), py::arg("state"), py::arg("h"),
        "energy, energy_post, residual and gap of the state (h: the step size in use).");
  m.def("momentum_maps",
        [](const PyModel& model, const State& s) {
          check_state(model, s);
          Vector out(static_cast<Eigen::Index>(model.model.momentum_maps().size()));
          evaluate_momentum_maps(model.model, s, out);
          return out;
        },
        py::arg("model"), py::arg("state"), "The model's momentum maps J(q, p~) at the state, in declaration order.");

  // The command line's scenes as models, for the low-level API (and the same model with and
  // without Python callbacks: benchmarks/python_overhead.py).
  m.def("build_scene",
        [](const std::string& scene, const std::map<std::string, double>& set) {
          const bool file = scenarios::is_scene_file(scene);
          if (file && !set.empty())
            throw py::value_error("set does not apply to a scene file (" + scene + "): edit the file");
          const scenarios::SceneInfo info = file ? scenarios::load_scene_file(scene) : scenarios::find_scene(scene);
          scenarios::Parameters p = info.defaults();
          for (const auto& [name, value] : set) p.set(name, value);
          scenarios::SceneSetup s = info.build(p);
          using namespace py::literals;
          return SimpleNamespace(py::module_::import("types").attr("SimpleNamespace")(
              "model"_a = PyModel{std::move(s.model), false}, "t0"_a = s.t0, "q0"_a = s.q0, "v0"_a = s.v0,
              "dt"_a = info.default_dt, "t_end"_a = info.default_t_end));
        },
        py::arg("scene"), py::arg("set") = std::map<std::string, double>{},
        R"(A built-in scene (or a scene file) with parameters set: a namespace with model, t0, q0, v0 (the
velocity guess start_from_velocity projects) and the scene's default dt and t_end.)");
}

// The quaternion helpers of nonholo/rigid_body.hpp.
void bind_quaternions(py::module_& m) {
  m.def("axis_angle_quaternion",
        [](const py::object& axis, double angle) {
          const Eigen::Vector4d q = axis_angle_quaternion(vector3(axis, "axis_angle_quaternion: axis"), angle);
          return py::array_t<double>(4, q.data());
        },
        py::arg("axis"), py::arg("angle"),
        "The unit quaternion (w, x, y, z) of the rotation by angle about axis (normalised; nonzero and finite).");
  m.def("quaternion_matrix",
        [](const py::object& q) {
          auto a = Array::ensure(q);
          if (!a) {
            PyErr_Clear();
            throw py::value_error("quaternion_matrix: expected 4 numbers (w, x, y, z), got " +
                                  callback_detail::type_name(q));
          }
          if (a.ndim() != 1 || a.size() != 4)
            throw py::value_error("quaternion_matrix: expected 4 numbers (w, x, y, z), got an array of " +
                                  std::to_string(a.size()) + " in " + std::to_string(a.ndim()) + " dimension(s)");
          const Eigen::Vector4d v(a.data()[0], a.data()[1], a.data()[2], a.data()[3]);
          if (!v.allFinite() || !(v.norm() > 0.0)) {
            std::ostringstream os;
            os << "quaternion_matrix: q = (" << num(v[0]) << ", " << num(v[1]) << ", " << num(v[2]) << ", " << num(v[3])
               << ") must be finite and nonzero";
            throw py::value_error(os.str());
          }
          return Eigen::Matrix3d(quaternion_matrix(v));
        },
        py::arg("q"),
        "The rotation matrix R of the quaternion q / ``|q|`` (w, x, y, z): R x = q x q^*, columns the body axes in space.");
}

}  // namespace

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
