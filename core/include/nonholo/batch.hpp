#pragma once
/// @file
/// Independent trajectories in parallel with OpenMP (parameter sweeps, Monte Carlo
/// ensembles). Each thread owns its Workspace (so its own CHOLMOD context); trajectory i is
/// computed exactly as it would be serially, so results are bit-identical whatever the number
/// of threads; no exception leaves the parallel region: every trajectory gets its own outcome.
#include <nonholo/model.hpp>
#include <nonholo/rattle.hpp>
#include <nonholo/state.hpp>
#include <nonholo/status.hpp>
#include <nonholo/workspace.hpp>

#include <exception>
#include <functional>
#include <string>
#include <vector>

namespace nonholo {

/// How integrate_batch runs its trajectories.
struct BatchOptions {
  int threads = 0;  ///< 0: all cores (omp_get_num_procs)
  WorkspaceOptions workspace;  ///< for each thread's Workspace
};

/// What became of one trajectory of integrate_batch.
struct BatchOutcome {
  Status status = Status::Ok;  ///< Ok, or why the trajectory stopped (InvalidInput: refused at set-up)
  std::string message;  ///< why it failed, or the exception's text
  long steps = 0;       ///< steps completed
  long restarts = 0;    ///< multiplier restarts in those steps (RattleOptions::restart)
  double parasitic_max = 0.0;  ///< largest parasitic amplitude measured (NaN if never measured)
};

/// The number of threads `requested` means here (0: all cores); at least 1.
int batch_threads(int requested);

/// Runs f and returns the text of the exception it threw ("" if none): how a job's failure is
/// kept as its own outcome here and in ensemble_for (nonholo/mpi_ensemble.hpp).
template <class F>
std::string capture_error(F&& f) {
  try {
    f();
  } catch (const std::exception& e) {
    return e.what();
  } catch (...) {
    return "unknown exception";
  }
  return {};
}

/// Runs job(i, thread) for i in [0, count) on `threads` threads (dynamic schedule). An
/// exception thrown by a job is caught and returned as that index's message ("" otherwise).
std::vector<std::string> parallel_for(long count, int threads, const std::function<void(long i, int thread)>& job);

/// One model, many initial states: each state advances by `steps` steps of step(). A failed
/// trajectory stops at its last good state (step() leaves it unchanged) with its status.
std::vector<BatchOutcome> integrate_batch(const Model& model, std::vector<State>& states, long steps,
                                          const RattleOptions& options, const BatchOptions& batch = {});

}  // namespace nonholo
