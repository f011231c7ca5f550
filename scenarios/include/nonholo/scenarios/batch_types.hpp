#pragma once
/// @file
/// The types of `nonholo batch` without its functions: the options (BatchConfig), the
/// processes a batch spreads over (BatchProcesses) and what it returns (BatchResult), apart from
/// run_batch() (<nonholo/scenarios/batch.hpp>) for the output files that write them.
#include <nonholo/ensemble.hpp>
#include <nonholo/scenarios/run_types.hpp>

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

namespace nonholo::scenarios {

/// Spreads a batch's trajectories over processes: MPI ranks under `mpirun nonholo batch`
/// (scenarios/cli/mpi_batch.hpp, with ensemble_for of nonholo/mpi_ensemble.hpp). Every
/// process calls run_batch with the same config; each trajectory runs on one of them and its row
/// goes to the writing process, which writes the output and gets the full result; the others
/// open no output and get a result with `ranks` set and no rows.
class BatchProcesses {
 public:
  virtual ~BatchProcesses() = default;
  virtual int size() const = 0;  ///< the number of processes
  virtual bool writes() const = 0;  ///< whether this process writes the output (and gets the rows)
  virtual int rank() const { return 0; }  ///< this process's number (the writing one is 0)
  /// Collective: job(i, thread) once for each i in [0, count) on some process, `threads`
  /// threads on each; every item in index order on the writing process, none elsewhere.
  /// Throws on every process when one of them called abandon() instead, or when their
  /// `command`s (BatchConfig::command) differ.
  virtual std::vector<EnsembleItem> run(long count, int threads, const std::string& command,
                                        const EnsembleJob& job) = 0;
  /// What a process that fails before run() calls instead (a no-op after it), so that the
  /// others do not wait for it forever.
  virtual void abandon() = 0;
};

/// One trajectory of a batch of a model built in code (BatchConfig::factory): the model, shared
/// (the batch keeps it until the trajectory has ended), and where it starts.
struct BatchModel {
  std::shared_ptr<const Model> model;  ///< the model of this trajectory
  RunStart start;                      ///< its start (t0, q0, v0; or a State)
};
/// Makes trajectory `trajectory`'s model and start from the values its varied parameters drew,
/// in BatchConfig::vary's order (batch_draws()).
using ModelFactory = std::function<BatchModel(const std::vector<double>& values, long trajectory)>;

/// The options of `nonholo batch` (run_batch()).
struct BatchConfig {
  RunConfig run;  ///< scene, `--set`, `--dt`, `--t-end`, `--method`, `--hitch`, ... (csv_path unused)
  long count = 0;  ///< the number of trajectories (at least 1)
  int threads = 0;  ///< 0: all cores
  std::vector<std::string> vary;  ///< NAME=LO:HI
  std::uint64_t seed = 1;  ///< the seed of the `--vary` draws (trajectory i draws from seed and i)
  std::string out;  ///< the per-trajectory table, CSV or HDF5 by the extension (empty: none)
  /// Every trajectory's whole final state (q and the momentum p the method carries) kept in
  /// BatchResult::states and, when `states` names a file, written there (HDF5: /q, /p, count rows).
  /// keep_states keeps them without writing them.
  ///@{
  std::string states;
  bool keep_states = false;
  ///@}
  BatchProcesses* processes = nullptr;  ///< MPI ranks (not owned); null: this process alone
  /// A batch of a model built in code instead of a scene (run.scene then names it; empty:
  /// "model"): called once per trajectory on the batch's threads, several at once (it must be
  /// safe to call so), with the values of `vary`, whose names are the factory's own. run.dt and
  /// run.t_end are required, run.assignments must be empty. Under MPI every process calls it for
  /// its own trajectories.
  ModelFactory factory;
  /// The batch's options as parsed, one `name=value` a line (`--threads` left out: each process may
  /// have its own cores); the processes check that they all run the same.
  std::string command;
};

/// What run_batch() returns (the rows only on the writing process).
struct BatchResult {
  RunSummary aggregate;  ///< max of the errors, total steps, wall time of the whole batch
  long trajectories = 0;  ///< the number run (BatchConfig::count)
  int threads = 0;  ///< per process
  int ranks = 0;    ///< processes under MPI (the line then says ranks=); 0: not under MPI
  long failed = 0;  ///< trajectories whose status is not ok
  long inaccurate = 0;  ///< of the failed: those that ended with status=inaccurate (their results are whole)
  std::string first_failure;  ///< "trajectory i: ..." of the first failed one
  std::string line() const;   ///< the summary line

  /// What the CSV holds, one entry per trajectory in order: the varied parameters' values
  /// (named in `varied`), the first coordinates of the final state (named in `shown`, at most
  /// three: body 0's; NaN when the trajectory was not set up) and the trajectory's summary.
  struct Trajectory {
    std::vector<double> values;   ///< the varied parameters' values
    std::vector<double> final_q;  ///< the first coordinates of the final state
    RunSummary summary;           ///< the trajectory's own summary
  };
  /// The names of the varied parameters and of the coordinates shown.
  ///@{
  std::vector<std::string> varied, shown;
  ///@}
  std::vector<Trajectory> rows;  ///< one per trajectory, in order
  /// BatchConfig::keep_states or states: the final q (count x coordinates.size(), row-major) and
  /// p (count x velocities.size()); NaN rows for trajectories that were not set up.
  struct States {
    /// The names of q's and p's entries.
    ///@{
    std::vector<std::string> coordinates, velocities;
    ///@}
    /// Row-major, one row per trajectory.
    ///@{
    std::vector<double> q, p;
    ///@}
  } states;  ///< the final states (see States)
};

}  // namespace nonholo::scenarios
