// `nonholo batch` (run_batch) as named phases: the options checked and the run prepared once,
// the outputs opened, the trajectories integrated (threads, and MPI ranks through
// BatchProcesses) with each finished row journaled, then the table, the summary and the files.
#include <nonholo/scenarios/batch.hpp>

#include <nonholo/scenarios/interrupt.hpp>
#include <nonholo/scenarios/scene_file.hpp>

#include <nonholo/batch.hpp>
#include <nonholo/sparse/big_buffer.hpp>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <fstream>
#include <limits>
#include <memory>
#include <mutex>
#include <optional>
#include <sstream>
#include <stdexcept>

#include "batch/aggregate.hpp"
#include "output/batch_row.hpp"
#include "output/batch_table.hpp"
#include "output/file_identity.hpp"
#include "output/hdf5_output.hpp"
#include "output/replacing_file.hpp"
#include "run/run_internal.hpp"
#include "scenes/random.hpp"

namespace nonholo::scenarios {
namespace {

struct Variation {
  std::string name;
  double lo, hi;
};

Variation parse_variation(const std::string& text) {
  const auto eq = text.find('='), colon = text.find(':', eq == std::string::npos ? 0 : eq);
  if (eq == std::string::npos || colon == std::string::npos || eq == 0)
    throw std::invalid_argument("--vary '" + text + "': expected NAME=LO:HI");
  Variation v{text.substr(0, eq), 0.0, 0.0};
  v.lo = parse_number(text.substr(eq + 1, colon - eq - 1), "--vary " + text);
  v.hi = parse_number(text.substr(colon + 1), "--vary " + text);
  if (!(v.lo <= v.hi)) throw std::invalid_argument("--vary " + text + ": LO must not exceed HI");
  return v;
}

// Trajectory i's draws: they depend on (seed, trajectory, variation) only.
std::vector<double> draws(const std::vector<Variation>& variations, std::uint64_t seed, long i) {
  Random random(seed * 0x9E3779B97F4A7C15ull + static_cast<std::uint64_t>(i));
  std::vector<double> values;
  for (const auto& v : variations) values.push_back(v.lo + (v.hi - v.lo) * random.uniform());
  return values;
}

// Ctrl-C (or the caller's stop) before trajectory i began: marked interrupted, not set up.
bool stop_before_start(const RunConfig& config, const PreparedRun& prepared, RunSummary& summary) {
  const bool ctrl_c = interrupt_requested();
  if (!ctrl_c && !(config.stop && config.stop->load(std::memory_order_relaxed))) return false;
  summary.scene = prepared.info.name;
  summary.method = config.method;
  summary.status = Status::Interrupted;
  summary.message = (ctrl_c ? std::string("interrupted (") + interrupt_name() + ")" : std::string("interrupted by the caller")) +
                    " before this trajectory started";
  summary.t_final = std::numeric_limits<double>::quiet_NaN();
  return true;
}

// The rows' final states into count x n arrays, NaN where a trajectory has none (its set-up
// failed) or one of another size.
void gather_states(const std::vector<Row>& rows, BatchResult::States& out) {
  for (const Row& r : rows)
    if (!r.coordinates.empty()) {
      out.coordinates = r.coordinates;
      out.velocities = r.velocities;
      break;
    }
  const std::size_t nq = out.coordinates.size(), nv = out.velocities.size();
  out.q.assign(rows.size() * nq, std::numeric_limits<double>::quiet_NaN());
  out.p.assign(rows.size() * nv, std::numeric_limits<double>::quiet_NaN());
  for (std::size_t i = 0; i < rows.size(); ++i) {
    const Row& r = rows[i];
    if (static_cast<std::size_t>(r.final_q.size()) == nq && static_cast<std::size_t>(r.final_p.size()) == nv) {
      std::copy(r.final_q.data(), r.final_q.data() + nq, out.q.begin() + static_cast<std::ptrdiff_t>(i * nq));
      std::copy(r.final_p.data(), r.final_p.data() + nv, out.p.begin() + static_cast<std::ptrdiff_t>(i * nv));
    }
  }
}

// One batch: what its phases share.
class BatchRun {
 public:
  explicit BatchRun(const BatchConfig& config) : config_(config) {}
  BatchResult run();

 private:
  void check_options();     // before anything is prepared or opened
  void prepare();           // the run's options once, the parameters and their variations
  void open_outputs();      // the table's file (before integrating: its path must be writable), the journal
  bool integrate();         // every trajectory; false on a process that does not write the output
  void integrate_here();    // on this process's threads
  bool integrate_spread();  // over the processes (MPI ranks)
  void integrate_row(long i, Row& row);
  TrajectoryResult integrate_made(long i, const std::vector<double>& values, const TrajectoryHooks& hooks);
  void journal_row(long i, int thread, const Row& row);
  void keep(long i, Row& row);
  BatchResult tabulate();                // the summary and the table's columns
  void write_outputs(BatchResult& result);  // the table, the states, the journal removed

  const BatchConfig& config_;
  std::chrono::steady_clock::time_point start_;
  std::string out_path_;  // only the writing process opens the output
  bool keep_states_ = false;
  RunConfig run_config_;
  PreparedRun prepared_;
  std::optional<Parameters> base_;  // the scene's defaults with --set (set in prepare)
  std::vector<Variation> variations_;
  std::vector<std::string> varied_;
  // The table and the states, each written to a temporary made before integrating (so an
  // unwritable place fails first) and renamed over its file at the end: a batch that fails or is
  // interrupted leaves an existing file as it was.
  std::unique_ptr<ReplacingFile> out_file_, states_file_;
  std::unique_ptr<Journal> journal_;
  std::unique_ptr<Progress> progress_;
  int threads_ = 0;
  std::vector<BatchResult::Trajectory> rows_;  // all of them, on the writing process only
  std::vector<std::string> errors_;
  // Body 0's coordinate names from the set-up trajectory of lowest index: one copy, not one a row;
  // a row copies them (and takes the lock) only while its index is below the lowest so far.
  std::mutex names_mutex_;
  std::atomic<long> names_from_{0};
  std::vector<std::string> names_;
  std::vector<Row> states_;  // --states: each row's whole final state, gathered at the end
};

BatchResult BatchRun::run() {
  check_options();
  prepare();
  open_outputs();
  if (!integrate()) {  // its rows reached the writing process
    BatchResult share;
    share.trajectories = config_.count;
    share.threads = threads_;
    share.ranks = config_.processes->size();
    return share;
  }
  BatchResult result = tabulate();
  write_outputs(result);
  return result;
}

void BatchRun::check_options() {
  out_path_ = !config_.processes || config_.processes->writes() ? config_.out : std::string();
  keep_states_ = config_.keep_states || !config_.states.empty();
  if (!config_.states.empty() && !is_hdf5_path(config_.states))
    throw std::invalid_argument("--states " + config_.states + ": the states are written as HDF5: name the file .h5");
  for (const auto& v : config_.vary)
    if (keep_states_ && v.compare(0, 7, "bodies=") == 0)
      throw std::invalid_argument("--states with --vary bodies: the final states would differ in size; vary other "
                                  "parameters, or run one batch per size");
  if (!config_.out.empty() && !is_hdf5_path(config_.out) && !is_csv_path(config_.out))
    throw std::invalid_argument("--out " + config_.out + ": name the file .csv (text) or .h5 / .hdf5 (HDF5)");
  // `--out b.h5 --states b.h5` wrote the states over the table (file_identity.hpp).
  refuse_shared_files({{"--out", config_.out}, {"--states", config_.states}},
                      {{"the scene file", !config_.factory && is_scene_file(config_.run.scene) ? config_.run.scene : ""}});
  start_ = std::chrono::steady_clock::now();
  if (config_.count < 1) throw std::invalid_argument("--count " + std::to_string(config_.count) + ": must be at least 1");
  if (config_.threads < 0)
    throw std::invalid_argument("--threads " + std::to_string(config_.threads) + ": must be positive");
}

void BatchRun::prepare() {
  run_config_ = config_.run;
  run_config_.threads = 1;  // the batch's threads run trajectories, each on one
  run_config_.csv_path.clear();
  run_config_.sink = nullptr;
  if (config_.factory) {  // a model built in code: the factory reads the varied values itself
    prepared_ = prepare_model_run(run_config_, 0.0);
    base_.emplace(prepared_.info.name, std::vector<ParameterSpec>{});
    for (const auto& text : config_.vary) variations_.push_back(parse_variation(text));
    for (const auto& v : variations_) varied_.push_back(v.name);
    return;
  }
  prepared_ = prepare_run(run_config_);
  base_.emplace(prepared_.info.defaults());
  for (const auto& a : config_.run.assignments) base_->assign(a);
  for (const auto& text : config_.vary) {
    variations_.push_back(parse_variation(text));
    Parameters check = *base_;  // the name must be one of the scene's (throws otherwise)
    check.set(variations_.back().name, variations_.back().lo);
  }
  for (const auto& v : variations_) varied_.push_back(v.name);
}

void BatchRun::open_outputs() {
  if (!out_path_.empty()) out_file_ = std::make_unique<ReplacingFile>(out_path_);
  if (!config_.states.empty() && (!config_.processes || config_.processes->writes()))
    states_file_ = std::make_unique<ReplacingFile>(config_.states);
  journal_ = std::make_unique<Journal>(config_.out, config_.processes, config_.run.error_estimate);
}

bool BatchRun::integrate() {
  check_batch_memory(config_);
  threads_ = batch_threads(config_.threads);
  names_from_ = config_.count;
  if (keep_states_) states_.resize(static_cast<std::size_t>(config_.count));
  // Over several MPI ranks each sees only its own share: no bar then.
  const bool spread = config_.processes && config_.processes->size() > 1;
  progress_ = std::make_unique<Progress>("batch " + prepared_.info.name, spread ? 0 : config_.count,
                                         config_.run.verbosity);
  journal_->begin(threads_);
  if (!config_.processes)
    integrate_here();
  else if (!integrate_spread())
    return false;
  progress_->finish();
  return true;
}

void BatchRun::integrate_here() {
  // A row's summary is 0.6 kB: 200 000 single sleighs' rows are 125 MB, made before the
  // threads start; in huge pages they take a tenth of the time (0.39 s on the development machine).
  sparse::reserve_buffer(rows_, static_cast<std::size_t>(config_.count));
  rows_.resize(static_cast<std::size_t>(config_.count));
  errors_ = parallel_for(config_.count, threads_, [&](long i, int thread) {
    Row row;  // a failed set-up keeps its drawn values in the table
    const std::string error = capture_error([&] { integrate_row(i, row); });
    row.error = error;
    journal_row(i, thread, row);
    keep(i, row);
    if (!error.empty()) throw std::runtime_error(error);
  });
  journal_->flush();
}

// Each row comes back as bytes, with what a failed set-up left in it (the drawn values).
bool BatchRun::integrate_spread() {
  auto items = config_.processes->run(config_.count, threads_, config_.command, [&](long i, int thread) {
    Row row;
    row.error = capture_error([&] { integrate_row(i, row); });
    journal_row(i, thread, row);
    return pack_row(row, keep_states_);
  });
  journal_->flush();
  if (!config_.processes->writes()) {
    journal_->remove();  // its rows reached the writing process
    return false;
  }
  rows_.resize(items.size());
  errors_.resize(items.size());
  for (std::size_t i = 0; i < items.size(); ++i) {
    Row row;
    if (items[i].error.empty()) row = unpack_row(items[i].data);
    errors_[i] = items[i].error.empty() ? row.error : items[i].error;
    if (row.values.size() != variations_.size())  // the job itself failed: keep the table's columns
      row.values.assign(variations_.size(), std::numeric_limits<double>::quiet_NaN());
    keep(static_cast<long>(i), row);
    items[i] = EnsembleItem{};  // the bytes are not needed twice
  }
  return true;
}

void BatchRun::integrate_row(long i, Row& row) {
  row.values = draws(variations_, config_.seed, i);
  if (stop_before_start(run_config_, prepared_, row.summary)) {
    progress_->add(1);
    return;
  }
  TrajectoryHooks hooks;
  hooks.setup_status = i == 0 ? progress_.get() : nullptr;  // the first shows its set-up until the bar
  hooks.on_model = [this, i, &row](const Model& model) {
    if (i >= names_from_.load(std::memory_order_relaxed)) return;  // a lower row has them
    const auto& names = model.coordinate_names();
    row.names.assign(names.begin(), names.begin() + std::min<std::size_t>(3, names.size()));
  };
  hooks.final_q = true;
  hooks.final_state = keep_states_;
  TrajectoryResult r = config_.factory ? integrate_made(i, row.values, hooks) : integrate_scene(prepared_, [&] {
    Parameters p = *base_;
    for (std::size_t v = 0; v < variations_.size(); ++v) p.set(variations_[v].name, row.values[v]);
    return p;
  }(), run_config_, hooks);
  row.summary = std::move(r.summary);
  row.summary.threads = 0;  // the batch line reports its own threads
  row.final_q = std::move(r.final_q);
  if (keep_states_) {
    row.final_p = std::move(r.final_p);
    row.coordinates = std::move(r.coordinates);
    row.velocities = std::move(r.velocities);
  }
  progress_->add(1);
}

// Trajectory i of a model built in code: the factory's model and start (a start at t0 != 0 counts
// its steps from there: the run's options prepared again for it).
TrajectoryResult BatchRun::integrate_made(long i, const std::vector<double>& values, const TrajectoryHooks& hooks) {
  const BatchModel made = config_.factory(values, i);
  if (!made.model) throw std::invalid_argument("the factory gave trajectory " + std::to_string(i) + " no model");
  const double t0 = made.start.state ? made.start.state->t : made.start.t0;
  if (t0 == 0.0) return integrate_model(prepared_, *made.model, made.start, *base_, run_config_, hooks);
  const PreparedRun later = prepare_model_run(run_config_, t0);
  return integrate_model(later, *made.model, made.start, *base_, run_config_, hooks);
}

// A finished row into the journal: body 0's first three coordinates (NaN where there are fewer
// or the set-up failed), as the table shows them.
void BatchRun::journal_row(long i, int thread, const Row& row) {
  if (!journal_->active()) return;
  BatchResult::Trajectory r{row.values, std::vector<double>(3, std::numeric_limits<double>::quiet_NaN()), row.summary};
  for (Eigen::Index c = 0; c < std::min<Eigen::Index>(3, row.final_q.size()); ++c)
    r.final_q[static_cast<std::size_t>(c)] = row.final_q[c];
  if (!row.error.empty()) {
    r.summary.status = Status::InvalidInput;
    r.summary.message = row.error;
  }
  std::vector<std::string> names3 = row.names;
  if (names3.size() < 3) names3 = {"q0", "q1", "q2"};
  journal_->add(i, thread, r, varied_, names3);
}

void BatchRun::keep(long i, Row& row) {
  if (keep_states_) {
    Row& s = states_[static_cast<std::size_t>(i)];
    s.final_q = row.final_q;
    s.final_p = std::move(row.final_p);
    s.coordinates = std::move(row.coordinates);
    s.velocities = std::move(row.velocities);
  }
  if (!row.names.empty() && i < names_from_.load(std::memory_order_relaxed)) {
    const std::lock_guard<std::mutex> lock(names_mutex_);
    if (i < names_from_.load(std::memory_order_relaxed)) {
      names_from_.store(i, std::memory_order_relaxed);
      names_ = std::move(row.names);
    }
  }
  // The table shows at most three final coordinates: keep no more (a large model's state).
  const auto kept = std::min<Eigen::Index>(3, row.final_q.size());
  rows_[static_cast<std::size_t>(i)] = {std::move(row.values),
                                        std::vector<double>(row.final_q.data(), row.final_q.data() + kept),
                                        std::move(row.summary)};
}

// The columns: varied parameters, final time, body 0's coordinates, the errors. The names come
// from a trajectory that was set up (no model is built again just for them: a large one takes
// seconds); if none was, from the fixed parameters alone.
BatchResult BatchRun::tabulate() {
  BatchResult result;
  result.trajectories = config_.count;
  result.threads = threads_;
  result.ranks = config_.processes ? config_.processes->size() : 0;
  aggregate(prepared_, config_, rows_, errors_, result);
  if (names_.empty()) {
    names_ = {"q0", "q1", "q2"};
    if (!config_.factory) try {
      names_ = prepared_.info.build(*base_).model.coordinate_names();
    } catch (const std::exception&) {  // the fixed parameters alone are not a valid scene
    }
  }
  const std::size_t shown = std::min<std::size_t>(3, names_.size());
  result.varied = varied_;
  result.shown.assign(names_.begin(), names_.begin() + static_cast<std::ptrdiff_t>(shown));
  for (BatchResult::Trajectory& r : rows_) r.final_q.resize(shown, std::numeric_limits<double>::quiet_NaN());
  result.rows = std::move(rows_);
  if (keep_states_) gather_states(states_, result.states);
  return result;
}

void BatchRun::write_outputs(BatchResult& result) {
  BatchConfig used = config_;  // with the dt and t_end the run used (the files' attributes)
  used.run.dt = prepared_.dt;
  used.run.t_end = prepared_.t_end;
  if (out_file_) {  // CSV, or HDF5 by the extension (hdf5_output.hpp)
    if (is_hdf5_path(out_path_)) {
      write_batch_hdf5(out_file_->temporary(), used, prepared_.info.name, result, prepared_.steps);
    } else {
      std::ofstream out(out_file_->temporary());
      if (!out) throw std::runtime_error("error writing '" + out_path_ + "': " + std::strerror(errno));
      write_batch_csv(out, out_path_, result, config_.run.error_estimate);
    }
    out_file_->commit();
  }
  if (states_file_) {
    write_batch_states(states_file_->temporary(), used, prepared_.info.name, result, prepared_.steps);
    states_file_->commit();
  }
  journal_->remove();
  result.aggregate.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
}

}  // namespace

std::string BatchResult::line() const {
  std::ostringstream os;
  os << aggregate.line() << " trajectories=" << trajectories << " threads=" << threads << " failed=" << failed;
  if (ranks > 0) os << " ranks=" << ranks;
  return os.str();
}

BatchResult run_batch(const BatchConfig& config) { return BatchRun(config).run(); }

std::vector<double> batch_draws(const BatchConfig& config, long trajectory) {
  std::vector<Variation> variations;
  for (const auto& text : config.vary) variations.push_back(parse_variation(text));
  return draws(variations, config.seed, trajectory);
}

}  // namespace nonholo::scenarios
