// Stepping in Python: State (picklable, read-only views), Workspace, the starts, step and steps,
// diagnose and build_scene. The step, the multi-step loop and diagnose release the GIL for a
// model that never calls Python; with Python callbacks they keep it (each callback would
// otherwise take it back, at a cost per call). The callbacks take it anyway (callbacks.hpp),
// so a release is never unsafe.
#include <nonholo/scenarios/scene.hpp>
#include <nonholo/scenarios/scene_file.hpp>

#include <chrono>
#include <map>

#include "bind_common.hpp"

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

}  // namespace

namespace {

// The state's time, vectors (read-only copies, assigned whole), counters and momenta.
void state_fields(py::class_<State>& c) {
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
  c.def_readonly("t", &State::t, "t_k = t0 + k h, the state's time (on its time grid, never summed step by step).")
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
      .def("__deepcopy__", [](const State& s, const py::object&) { return s; });
}

}  // namespace

void bind_state(py::module_& m) {
  py::class_<State> c(m, "State", R"(The integrator state (t_k, q_k, p~_k, lambda~_k, force_k), made by start_from_velocity or
start_from_two_points and advanced by step().

q, p, lam (the multipliers) and force are returned as fresh read-only float64 copies: a step
swaps the state's vectors with the workspace's buffers, so a view would change meaning under
it, and writing into a copy would be lost silently. Assigning a whole array (state.q = ...)
copies it in; it is then up to you to keep the state consistent (force = f + mu^T lam), and
setting q or p resets target_energy.)");
  state_fields(c);
  // Pickled whole (every field, the time grid and the restart schedule too), bit for bit: a
  // state saved and loaded steps on exactly as the original would.
  c.def(py::pickle(
          [](const State& s) {
            const auto array = [](const Vector& v) { return py::array_t<double>(v.size(), v.data()); };
            return py::make_tuple(1, s.t, s.grid.t0, s.grid.h, s.grid.k, array(s.q), array(s.p), array(s.lambda),
                                  array(s.force), s.steps, s.restarts, s.watch.next_step, s.watch.last_step,
                                  s.watch.last_amplitude, s.watch.floor, s.target_energy);
          },
          [](const py::tuple& t) {
            if (t.size() != 16 || t[0].cast<int>() != 1)
              throw std::invalid_argument("State: not a pickled nonholo.State of this version");
            const auto to_vector = [](const py::handle& h) {
              const auto a = h.cast<py::array_t<double, py::array::c_style | py::array::forcecast>>();
              return Vector(Eigen::Map<const Vector>(a.data(), a.size()));
            };
            State s;
            s.t = t[1].cast<double>();
            s.grid.t0 = t[2].cast<double>();
            s.grid.h = t[3].cast<double>();
            s.grid.k = t[4].cast<long>();
            s.q = to_vector(t[5]);
            s.p = to_vector(t[6]);
            s.lambda = to_vector(t[7]);
            s.force = to_vector(t[8]);
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

namespace {

// Workspace: the buffers and factorisation of one thread.
void bind_workspace(py::module_& m) {
  py::class_<Workspace>(m, "Workspace", R"(Every buffer and the factorisation one thread needs to integrate a model
(one Workspace per thread; it keeps its model alive). backend: 'auto', 'block-diagonal',
'dense', 'banded', 'cholmod-natural' or 'cholmod-amd'. threads splits one step of a chain of knife
edges and hitches (either hitch mode) over that many threads, at most half its bodies
(ValueError above); other models and steps run on one (see the threads property). message says
why the last call failed. One call at a time: see step().)")
      .def(py::init([](const PyModel& model, const std::string& backend, bool composed_steps, bool dla_steps,
                       int threads) {
             WorkspaceOptions o;
             o.backend = sparse::backend_from_string(backend);
             o.composed_steps = composed_steps;
             o.dla_steps = dla_steps;
             o.threads = threads;
             return std::make_unique<Workspace>(model.model, o);
           }),
           py::arg("model"), py::arg("backend") = "auto", py::kw_only(), py::arg("composed_steps") = true,
           py::arg("dla_steps") = true, py::arg("threads") = 1, py::keep_alive<1, 2>())
      .def_property_readonly("threads", &Workspace::threads,
                             "The threads a step of this model uses (threads where it applies, else 1).")
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
}

// The starts, step and steps.
void bind_steps(py::module_& m) {
  m.def("start_from_velocity",
        [](const PyModel& model, Workspace& ws, double t0, const Vector& q0, const Vector& v0,
           const std::string& multiplier, double min_pivot_ratio, double max_gap) {
          check_pair(model, ws);
          StartOptions o;
          if (multiplier == "zero") o.multiplier = InitialMultiplier::Zero;
          else if (multiplier != "continuous")
            throw py::value_error("multiplier '" + multiplier + "': expected continuous or zero");
          o.min_pivot_ratio = min_pivot_ratio;
          o.max_gap = max_gap;
          return start_from_velocity(model.model, ws, t0, q0, v0, o);
        },
        py::arg("model"), py::arg("ws"), py::arg("t0"), py::arg("q0"), py::arg("v0"), py::kw_only(),
        py::arg("multiplier") = "continuous", py::arg("min_pivot_ratio") = StartOptions{}.min_pivot_ratio,
        py::arg("max_gap") = StartOptions{}.max_gap,
        R"(The state at (t0, q0) with the velocity guess v0 projected M-orthogonally onto D(q0). q0 has
n_q entries (a rigid body's quaternion of norm 1 within 1e-6, normalised here), v0 n_v (a rigid
body: Omega in its body frame, then its centre's velocity). Closed hitches must hold at q0: a
gap above max_gap x (1 + max(abs(q0))) is refused (ValueError naming the hitch); max_gap=inf lets
the first step close it.)");
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
}

// Diagnostics, diagnose, momentum_maps and build_scene.
void bind_diagnostics(py::module_& m) {
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

}  // namespace

void bind_stepping(py::module_& m) {
  bind_workspace(m);
  bind_steps(m);
  bind_diagnostics(m);
}

}  // namespace nonholo::python
