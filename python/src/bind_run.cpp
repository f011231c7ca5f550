// The scenes and the command-line tool's run and batch in Python. Both take the tool's own
// arguments (nonholo/__init__.py turns keywords into them), so that options are checked, and
// refused, with the tool's messages, and a run computes exactly what `nonholo run` computes.
// The C++ runs without the GIL (scenes call no Python; a model's callables take it); frames go into
// arrays instead of CSV. A model built in code runs the same way (_run_model).
#include <nonholo/scenarios/batch.hpp>
#include <nonholo/scenarios/command_line.hpp>
#include <nonholo/scenarios/run.hpp>
#include <nonholo/scenarios/scene.hpp>

#include <pybind11/numpy.h>
#include <pybind11/stl.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <future>
#include <iostream>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "bind_common.hpp"
#include "bindings.hpp"

namespace nonholo::python {
namespace {

namespace py = pybind11;
using scenarios::BatchResult;
using scenarios::RunSummary;
using scenarios::SummaryField;

// A 1-D or 2-D float64 array that takes over `data` (no copy).
py::array_t<double> take(std::vector<double>&& data, std::vector<py::ssize_t> shape) {
  auto* owned = new std::vector<double>(std::move(data));
  py::capsule free(owned, [](void* p) { delete static_cast<std::vector<double>*>(p); });
  return py::array_t<double>(shape, owned->data(), free);
}

// The frames of a run, kept in memory; between steps it lets Python's signal handlers run
// (Ctrl-C raises KeyboardInterrupt there) every 20-100 ms: the clock is read every `stride_`
// steps, a stride that adapts to the step's cost, and the GIL taken only when it is time.
class ArraySink : public scenarios::FrameSink {
 public:
  void begin(const std::vector<std::string>& coordinates) override { names = coordinates; }
  void velocities(const std::vector<std::string>& names_of_p) override { velocity_names = names_of_p; }
  void frame(double time, ConstVecRef q_now, ConstVecRef p_now, const Diagnostics& d) override {
    t.push_back(time);
    q.insert(q.end(), q_now.data(), q_now.data() + q_now.size());
    p.insert(p.end(), p_now.data(), p_now.data() + p_now.size());
    energy.push_back(d.energy);
    energy_post.push_back(d.energy_post);
    residual.push_back(d.residual);
    gap.push_back(d.gap);
  }
  void progress(double time, double fraction) override {
    now_t_ = time;
    now_fraction_ = fraction;
  }
  bool stop_requested() override {
    if (++count_ < stride_) return false;
    count_ = 0;
    const auto now = Clock::now();
    const double since = std::chrono::duration<double>(now - last_).count();
    if (since < 0.02) {  // too soon: read the clock less often
      if (stride_ < (1L << 20)) stride_ *= 2;
      return false;
    }
    if (since > 0.1 && stride_ > 1) stride_ /= 2;
    last_ = now;
    py::gil_scoped_acquire gil;
    if (PyErr_CheckSignals() == 0 && report_progress()) return false;
    if (!error) error.emplace();  // fetches the exception the handler (or the progress callable) raised
    return true;
  }
  // The caller's progress callable with the latest step's t and fraction (GIL held); false, with
  // its exception pending, if it raised.
  bool report_progress() {
    if (on_progress.is_none() || std::isnan(now_t_)) return true;
    try {
      on_progress(now_t_, now_fraction_);
      return true;
    } catch (py::error_already_set& e) {
      e.restore();
      return false;
    }
  }

  std::vector<std::string> names, velocity_names;
  std::vector<double> t, q, p, energy, energy_post, residual, gap;
  std::optional<py::error_already_set> error;
  py::object on_progress = py::none();  // progress(t, fraction), every 20-100 ms and at the end

 private:
  using Clock = std::chrono::steady_clock;
  long count_ = 0, stride_ = 1;
  Clock::time_point last_ = Clock::now();
  double now_t_ = std::numeric_limits<double>::quiet_NaN(), now_fraction_ = 0.0;
};

py::dict summary_dict(const RunSummary& s) {
  py::dict d;
  for (const SummaryField& f : s.fields()) {
    if (f.kind == SummaryField::Number)
      d[f.key.c_str()] = f.number;
    else if (f.kind == SummaryField::Integer)
      d[f.key.c_str()] = f.integer;
    else
      d[f.key.c_str()] = f.text;
  }
  d["message"] = s.message;
  d["warning"] = s.warning;
  d["threads_note"] = s.threads_note;
  py::list warnings;  // one by one with their kinds (nonholo.run raises them as Python warnings)
  for (const scenarios::RunWarning& w : s.warnings) {
    py::dict one;
    one["kind"] = scenarios::to_string(w.kind);
    one["text"] = w.text;
    warnings.append(one);
  }
  d["warning_list"] = warnings;
  return d;
}

// A run's summary and frames as the dict nonholo.RunResult reads.
py::dict run_dict(const RunSummary& summary, ArraySink& sink) {
  const auto frames = static_cast<py::ssize_t>(sink.t.size());
  const auto n = static_cast<py::ssize_t>(sink.names.size());
  const auto nv = static_cast<py::ssize_t>(sink.velocity_names.empty() ? sink.names.size() : sink.velocity_names.size());
  py::dict out;
  out["summary"] = summary_dict(summary);
  out["line"] = summary.line();
  out["coordinates"] = sink.names;
  out["velocities"] = sink.velocity_names.empty() ? sink.names : sink.velocity_names;
  out["t"] = take(std::move(sink.t), {frames});
  out["q"] = take(std::move(sink.q), {frames, n});
  out["p"] = take(std::move(sink.p), {frames, nv});
  out["gap"] = take(std::move(sink.gap), {frames});
  out["energy"] = take(std::move(sink.energy), {frames});
  out["energy_post"] = take(std::move(sink.energy_post), {frames});
  out["residual"] = take(std::move(sink.residual), {frames});
  if (sink.error) {  // Ctrl-C: the caller raises it with these results attached
    out["interrupt"] = sink.error->value();
  }
  return out;
}

// Python callables as stop conditions: (name, f(t, q) -> truth value, every). Each call takes the
// GIL and gets a copy of q; an exception (or a result without a truth value) fails the run with
// status=callback-failed naming it.
std::vector<scenarios::StopCondition> stop_conditions(const py::list& given) {
  std::vector<scenarios::StopCondition> out;
  for (const py::handle item : given) {
    const auto entry = item.cast<py::tuple>();
    scenarios::StopCondition c;
    c.name = entry[0].cast<std::string>();
    c.every = entry[2].cast<long>();
    const Callable f(py::reinterpret_borrow<py::object>(entry[1]));
    const std::string what = c.name + "(t, q)";
    c.holds = [f, what](double t, ConstVecRef q) {
      return callback_detail::invoke(what.c_str(), [&] {
        const py::object result = f(t, callback_detail::copy(q));
        const int truth = PyObject_IsTrue(result.ptr());
        if (truth < 0) throw py::error_already_set();
        return truth == 1;
      });
    };
    out.push_back(std::move(c));
  }
  return out;
}

// The run's last progress call (the fraction reached) once it has ended, unless it was stopped.
void final_progress(ArraySink& sink) {
  if (!sink.error && !sink.report_progress()) sink.error.emplace();
}

py::dict run(const std::vector<std::string>& args, const py::list& conditions, const py::object& progress) {
  scenarios::RunConfig config = scenarios::parse_run_arguments(args);
  config.stop_conditions = stop_conditions(conditions);
  ArraySink sink;
  sink.on_progress = progress;
  config.sink = &sink;
  RunSummary summary;
  {
    py::gil_scoped_release release;
    summary = scenarios::run_scene(config);
  }
  final_progress(sink);
  return run_dict(summary, sink);
}

// A 1-D array of `size` numbers named `what`, for the start (ValueError otherwise).
Vector start_vector(const py::object& value, const char* what) {
  if (value.is_none()) return Vector();
  auto a = Array::ensure(value);
  if (!a) {
    PyErr_Clear();
    throw py::value_error(std::string(what) + ": expected a 1-D array of numbers, got " +
                          callback_detail::type_name(value));
  }
  if (a.ndim() != 1)
    throw py::value_error(std::string(what) + ": expected a 1-D array, got " + std::to_string(a.ndim()) +
                          " dimension(s)");
  return Eigen::Map<const Vector>(a.data(), a.size());
}

// A model built in code, run as a scene is (scenarios::run_model): the same arguments but the
// scene (args[0], the model's name), the start from t0, q0, v0 or a State. The run holds no GIL:
// a model's Python callables take it for each call.
py::dict run_model(const PyModel& model, const std::vector<std::string>& args, double t0, const py::object& q0,
                   const py::object& v0, const std::optional<State>& state, const py::list& conditions,
                   const py::object& progress) {
  scenarios::RunConfig config = scenarios::parse_run_arguments(args);
  config.stop_conditions = stop_conditions(conditions);
  scenarios::RunStart start;
  start.t0 = t0;
  start.q0 = start_vector(q0, "q0");
  start.v0 = start_vector(v0, "v0");
  start.state = state;
  ArraySink sink;
  sink.on_progress = progress;
  config.sink = &sink;
  RunSummary summary;
  {
    py::gil_scoped_release release;
    summary = scenarios::run_model(model.model, start, config);
  }
  final_progress(sink);
  return run_dict(summary, sink);
}

// Runs the batch on a thread of its own while this one, Python's, lets the signal handlers run
// every 50 ms: a handler that raises (Ctrl-C: KeyboardInterrupt) sets `stop`, the batch's
// trajectories end at their next step (status=interrupted) and no more start; the exception is
// kept in `error` for the caller to raise with the rows. (Handlers run on the main thread only:
// a batch started from another Python thread is not interrupted.)
BatchResult run_batch_polling(scenarios::BatchConfig config, std::optional<py::error_already_set>& error) {
  std::atomic<bool> stop{false};
  config.run.stop = &stop;
  std::future<BatchResult> done = std::async(std::launch::async, [&config] { return scenarios::run_batch(config); });
  for (;;) {
    {
      py::gil_scoped_release release;
      if (done.wait_for(std::chrono::milliseconds(50)) == std::future_status::ready) break;
    }
    if (!error && PyErr_CheckSignals() != 0) {
      error.emplace();  // fetches the exception the handler raised
      stop.store(true, std::memory_order_relaxed);
    }
  }
  return done.get();  // rethrows what run_batch threw (bad options)
}

// The batch's table as columns (the CSV's, same names and order) and its summary.
py::dict batch_dict(scenarios::BatchConfig& config, bool keep_states) {
  config.keep_states = keep_states;
  std::optional<py::error_already_set> interrupt;
  BatchResult result = run_batch_polling(config, interrupt);
  const std::size_t rows = result.rows.size();
  auto column = [&](auto value) {
    std::vector<double> c(rows);
    for (std::size_t i = 0; i < rows; ++i) c[i] = value(result.rows[i]);
    return take(std::move(c), {static_cast<py::ssize_t>(rows)});
  };
  py::dict columns;
  std::vector<long> index(rows), restarts(rows);
  std::vector<std::string> status(rows);
  for (std::size_t i = 0; i < rows; ++i) {
    index[i] = static_cast<long>(i);
    restarts[i] = result.rows[i].summary.restarts;
    status[i] = to_string(result.rows[i].summary.status);
  }
  columns["trajectory"] = py::array(py::cast(index));
  for (std::size_t v = 0; v < result.varied.size(); ++v)
    columns[result.varied[v].c_str()] = column([v](const BatchResult::Trajectory& r) { return r.values[v]; });
  columns["t_final"] = column([](const BatchResult::Trajectory& r) { return r.summary.t_final; });
  for (std::size_t c = 0; c < result.shown.size(); ++c)
    columns[result.shown[c].c_str()] = column([c](const BatchResult::Trajectory& r) { return r.final_q[c]; });
  columns["energy_rel_err_max"] = column([](const BatchResult::Trajectory& r) { return r.summary.energy_rel_err_max; });
  columns["energy_post_rel_err_max"] =
      column([](const BatchResult::Trajectory& r) { return r.summary.energy_post_rel_err_max; });
  columns["residual_max"] = column([](const BatchResult::Trajectory& r) { return r.summary.residual_max; });
  columns["gap_max"] = column([](const BatchResult::Trajectory& r) { return r.summary.gap_max; });
  columns["restarts"] = py::array(py::cast(restarts));
  columns["parasitic_max"] = column([](const BatchResult::Trajectory& r) { return r.summary.parasitic_max; });
  if (result.aggregate.has_work) {
    columns["work"] = column([](const BatchResult::Trajectory& r) {
      return r.summary.has_work ? r.summary.work : std::numeric_limits<double>::quiet_NaN();
    });
    columns["energy_balance_err_max"] =
        column([](const BatchResult::Trajectory& r) { return r.summary.energy_balance_err_max; });
  }
  if (config.run.error_estimate)
    columns["error_estimate"] = column([](const BatchResult::Trajectory& r) { return r.summary.error_estimate; });
  columns["status"] = py::array(py::cast(status));

  py::dict summary = summary_dict(result.aggregate);
  summary["trajectories"] = result.trajectories;
  summary["threads"] = result.threads;
  summary["failed"] = result.failed;
  summary["first_failure"] = result.first_failure;
  py::dict out;
  out["summary"] = summary;
  out["line"] = result.line();
  out["columns"] = columns;
  py::list messages;
  for (const auto& r : result.rows) messages.append(r.summary.message);
  out["messages"] = messages;
  if (keep_states || !config.states.empty()) {  // count x n, as the --states file's /q and /p
    auto& s = result.states;
    const auto count = static_cast<py::ssize_t>(rows);
    out["coordinates"] = s.coordinates;
    out["velocities"] = s.velocities;
    out["q"] = take(std::move(s.q), {count, static_cast<py::ssize_t>(s.coordinates.size())});
    out["p"] = take(std::move(s.p), {count, static_cast<py::ssize_t>(s.velocities.size())});
  }
  if (interrupt) out["interrupt"] = interrupt->value();  // raised by the caller with the rows
  return out;
}

py::dict batch(const std::vector<std::string>& args, bool keep_states) {
  scenarios::BatchConfig config = scenarios::parse_batch_arguments(args);
  return batch_dict(config, keep_states);
}

// The draws of `nonholo batch ARGS` (its --vary, --seed): count x varied, for a factory called
// before the batch (nonholo.batch(factory, ...)).
py::array_t<double> batch_draws(const std::vector<std::string>& args, long count) {
  const scenarios::BatchConfig config = scenarios::parse_batch_arguments(args);
  std::vector<double> all;
  for (long i = 0; i < count; ++i) {
    const std::vector<double> row = scenarios::batch_draws(config, i);
    all.insert(all.end(), row.begin(), row.end());
  }
  return take(std::move(all), {static_cast<py::ssize_t>(count), static_cast<py::ssize_t>(config.vary.size())});
}

// A batch of models built in Python (nonholo.batch(factory, ...)): `made` holds each trajectory's
// (model, t0, q0, v0, state), made by the factory on the calling thread before; the batch's
// threads take them in turn (the list keeps the models alive until it has ended).
py::dict batch_models(const std::vector<std::string>& args, bool keep_states, const py::list& made) {
  scenarios::BatchConfig config = scenarios::parse_batch_arguments(args);
  if (static_cast<long>(made.size()) != config.count)
    throw py::value_error("the factory made " + std::to_string(made.size()) + " trajectories for count " +
                          std::to_string(config.count));
  std::vector<scenarios::BatchModel> trajectories;
  for (const py::handle item : made) {
    const auto entry = item.cast<py::tuple>();
    const PyModel& model = entry[0].cast<const PyModel&>();
    scenarios::BatchModel m;
    m.model = std::shared_ptr<const Model>(std::shared_ptr<const Model>(), &model.model);  // not owned: `made` holds it
    m.start.t0 = entry[1].cast<double>();
    m.start.q0 = start_vector(entry[2], "q0");
    m.start.v0 = start_vector(entry[3], "v0");
    if (!entry[4].is_none()) m.start.state = entry[4].cast<State>();
    trajectories.push_back(std::move(m));
  }
  config.factory = [&trajectories](const std::vector<double>&, long i) {
    return trajectories[static_cast<std::size_t>(i)];
  };
  return batch_dict(config, keep_states);
}

py::list scenes() {
  py::list list;
  for (const auto& info : scenarios::scene_catalogue()) {
    py::list parameters;
    for (const auto& p : info.parameters) {
      py::dict d;
      d["name"] = p.name;
      d["default"] = p.default_value;
      d["description"] = p.description;
      parameters.append(d);
    }
    py::dict d;
    d["name"] = info.name;
    d["description"] = info.description;
    d["dt"] = info.default_dt;
    d["t_end"] = info.default_t_end;
    d["parameters"] = parameters;
    list.append(d);
  }
  return list;
}

// The nonholo executable's command line in this process (python -m nonholo, the wheel's nonholo
// command): its output on the process's standard streams, without the GIL (Ctrl-C: the tool's
// own handler, as in the executable).
int main_of(const std::vector<std::string>& args) {
  std::vector<const char*> argv{"nonholo"};
  for (const std::string& a : args) argv.push_back(a.c_str());
  py::gil_scoped_release release;
  const int code = scenarios::run_command_line(static_cast<int>(argv.size()), argv.data(), std::cout, std::cerr);
  std::cout.flush();
  return code;
}

}  // namespace

void bind_run(py::module_& m) {
  m.def("_main", &main_of, py::arg("args"),
        "the nonholo command line (run, batch, list, wp) with these arguments, on this process's standard "
        "output and error; its exit code");
  m.def("_run", &run, py::arg("args"), py::arg("conditions") = py::list(), py::arg("progress") = py::none(),
        "nonholo run with the command line's arguments (the scene first) and stop conditions in Python "
        "((name, f, every) tuples): a dict of the summary and arrays");
  m.def("_run_model", &run_model, py::arg("model"), py::arg("args"), py::arg("t0"), py::arg("q0"), py::arg("v0"),
        py::arg("state"), py::arg("conditions") = py::list(), py::arg("progress") = py::none(),
        "run() of a model built in code: the command line's arguments (the model's name first), its start and "
        "stop conditions in Python");
  m.def("_batch", &batch, py::arg("args"), py::arg("keep_states") = false,
        "nonholo batch with the command line's arguments: a dict of the summary and the table's columns (and "
        "the final states with keep_states)");
  m.def("_batch_draws", &batch_draws, py::arg("args"), py::arg("count"),
        "the values each trajectory of nonholo batch ARGS draws for its --vary parameters (count x varied)");
  m.def("_batch_models", &batch_models, py::arg("args"), py::arg("keep_states"), py::arg("made"),
        "nonholo batch of models built in Python: the command line's arguments (the model's name first) and "
        "each trajectory's (model, t0, q0, v0, state)");
  m.def("_scenes", &scenes, "the built-in scenes with their parameters, defaults and descriptions");
}

}  // namespace nonholo::python
