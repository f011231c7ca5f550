// Independent trajectories on OpenMP threads (batch.hpp): parallel_for, and integrate_batch with one
// workspace per thread and an outcome per trajectory.
#include <nonholo/batch.hpp>

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>

namespace nonholo {

int batch_threads(int requested) {
  const int n = requested > 0 ? requested : omp_get_num_procs();
  return n > 0 ? n : 1;
}

std::vector<std::string> parallel_for(long count, int threads, const std::function<void(long i, int thread)>& job) {
  std::vector<std::string> errors(static_cast<std::size_t>(count > 0 ? count : 0));
  const int t = batch_threads(threads);
  // Chunks of neighbouring indices: jobs that write neighbouring results (a vector of
  // States, say) would otherwise share cache lines across threads. About 64 chunks per thread
  // keep the load balanced; the result of a job never depends on its chunk.
  const long chunk = std::max(1L, count / (64L * t));
#pragma omp parallel for schedule(dynamic, chunk) num_threads(t)
  for (long i = 0; i < count; ++i) {
    std::string error = capture_error([&] { job(i, omp_get_thread_num()); });
    if (!error.empty()) errors[static_cast<std::size_t>(i)] = std::move(error);  // written on failure only
  }
  return errors;
}

std::vector<BatchOutcome> integrate_batch(const Model& model, std::vector<State>& states, long steps,
                                          const RattleOptions& options, const BatchOptions& batch) {
  validate(options);
  const int t = batch_threads(batch.threads);
  std::vector<BatchOutcome> out(states.size());
  // One workspace per thread, built inside the region by its own thread.
  std::vector<std::unique_ptr<Workspace>> workspaces(static_cast<std::size_t>(t));
  const auto errors = parallel_for(static_cast<long>(states.size()), t, [&](long i, int thread) {
    auto& ws = workspaces[static_cast<std::size_t>(thread)];
    if (!ws) ws = std::make_unique<Workspace>(model, batch.workspace);
    State& s = states[static_cast<std::size_t>(i)];
    const long restarts = s.restarts;
    long k = 0;
    Status status = Status::Ok;
    double parasitic = std::numeric_limits<double>::quiet_NaN();
    for (; k < steps && status == Status::Ok; ++k) {
      status = step(model, *ws, s, options);
      if (status == Status::Ok && !std::isnan(ws->parasitic))
        parasitic = std::isnan(parasitic) ? ws->parasitic : std::max(parasitic, ws->parasitic);
    }
    BatchOutcome& o = out[static_cast<std::size_t>(i)];  // written once, at the end
    o.status = status;
    o.steps = status == Status::Ok ? k : k - 1;
    o.restarts = s.restarts - restarts;
    o.parasitic_max = parasitic;
    if (status != Status::Ok) o.message = ws->message();
  });
  for (std::size_t i = 0; i < out.size(); ++i)
    if (!errors[i].empty()) {
      out[i].status = Status::LinearSolverFailure;
      out[i].message = errors[i];
    }
  return out;
}

}  // namespace nonholo
