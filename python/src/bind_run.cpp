// The scenes and the command-line tool's run and batch in Python. Both take the tool's own
// arguments (nonholo/__init__.py turns keywords into them), so that options are checked, and
// refused, with the tool's messages, and a run computes exactly what `nonholo run` computes.
// The C++ runs without the GIL (scenes call no Python); frames go into arrays instead of CSV.
#include <nonholo/scenarios/batch.hpp>
#include <nonholo/scenarios/command_line.hpp>
#include <nonholo/scenarios/run.hpp>
#include <nonholo/scenarios/scene.hpp>

#include <pybind11/numpy.h>
#include <pybind11/stl.h>

#include <atomic>
#include <chrono>
#include <future>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <vector>

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
    if (PyErr_CheckSignals() == 0) return false;
    error.emplace();  // fetches the exception the handler raised (KeyboardInterrupt)
    return true;
  }

  std::vector<std::string> names, velocity_names;
  std::vector<double> t, q, p, energy, energy_post, residual, gap;
  std::optional<py::error_already_set> error;

 private:
  using Clock = std::chrono::steady_clock;
  long count_ = 0, stride_ = 1;
  Clock::time_point last_ = Clock::now();
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
  return d;
}

py::dict run(const std::vector<std::string>& args) {
  scenarios::RunConfig config = scenarios::parse_run_arguments(args);
  ArraySink sink;
  config.sink = &sink;
  RunSummary summary;
  {
    py::gil_scoped_release release;
    summary = scenarios::run_scene(config);
  }
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
py::dict batch(const std::vector<std::string>& args, bool keep_states) {
  scenarios::BatchConfig config = scenarios::parse_batch_arguments(args);
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

}  // namespace

void bind_run(py::module_& m) {
  m.def("_run", &run, py::arg("args"),
        "nonholo run with the command line's arguments (the scene first): a dict of the summary and arrays");
  m.def("_batch", &batch, py::arg("args"), py::arg("keep_states") = false,
        "nonholo batch with the command line's arguments: a dict of the summary and the table's columns (and "
        "the final states with keep_states)");
  m.def("_scenes", &scenes, "the built-in scenes with their parameters, defaults and descriptions");
}

}  // namespace nonholo::python
