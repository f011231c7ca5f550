#include <nonholo/scenarios/batch.hpp>

#include <nonholo/batch.hpp>

#include <algorithm>
#include <charconv>
#include <chrono>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <limits>
#include <mutex>
#include <sstream>
#include <stdexcept>

#include "batch_row.hpp"
#include "interrupt.hpp"
#include "hdf5_output.hpp"
#include "random.hpp"
#include "run_internal.hpp"

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

std::string number(double x) {
  char buf[32];
  return std::string(buf, std::to_chars(buf, buf + sizeof buf, x).ptr);
}

// The batch table's CSV header and rows (`nonholo batch --out`, and the journal below).
void csv_header(std::ostream& out, const std::vector<std::string>& varied, const std::vector<std::string>& shown,
                bool has_work, bool error_estimate) {
  out << "trajectory";
  for (const auto& name : varied) out << "," << name;
  out << ",t_final";
  for (const auto& name : shown) out << "," << name;
  out << ",energy_rel_err_max,energy_post_rel_err_max,residual_max,gap_max,restarts,parasitic_max";
  if (has_work) out << ",work,energy_balance_err_max";
  if (error_estimate) out << ",error_estimate";
  out << ",status\n";
}

void csv_row(std::ostream& out, long i, const BatchResult::Trajectory& r, bool has_work, bool error_estimate) {
  const RunSummary& s = r.summary;
  out << i;
  for (double x : r.values) out << "," << number(x);
  out << "," << number(s.t_final);
  for (double x : r.final_q) out << "," << number(x);
  out << "," << number(s.energy_rel_err_max) << "," << number(s.energy_post_rel_err_max) << ","
      << number(s.residual_max) << "," << number(s.gap_max) << "," << s.restarts << "," << number(s.parasitic_max);
  if (has_work) out << "," << number(s.has_work ? s.work : NAN) << "," << number(s.energy_balance_err_max);
  if (error_estimate) out << "," << number(s.error_estimate);
  out << "," << to_string(s.status) << "\n";
}

// The batch's table as CSV: one row per trajectory, in order.
void write_batch_csv(std::ofstream& out, const std::string& path, const BatchResult& result, bool error_estimate) {
  const bool has_work = result.aggregate.has_work;
  csv_header(out, result.varied, result.shown, has_work, error_estimate);
  for (std::size_t i = 0; i < result.rows.size(); ++i)
    csv_row(out, static_cast<long>(i), result.rows[i], has_work, error_estimate);
  out.close();
  if (!out) throw std::runtime_error("error writing '" + path + "'");
}

// Rows as trajectories finish, in the order they finish, flushed one by one, beside the batch's
// output (OUT.partial.csv; under MPI each rank its own, OUT.partial.rankR.csv): a batch killed
// before it ends keeps every trajectory that finished (nonholo.load reads the file; the rows
// carry their trajectory index). Removed once the output is written.
class Journal {
 public:
  Journal(const std::string& out, const BatchProcesses* processes, bool error_estimate)
      : error_estimate_(error_estimate) {
    if (out.empty()) return;
    path_ = out + (processes && processes->size() > 1 ? ".partial.rank" + std::to_string(processes->rank()) : ".partial") +
            ".csv";
    file_.open(path_);
    if (!file_) throw std::invalid_argument("cannot open '" + path_ + "' for writing: " + std::strerror(errno));
  }
  // A finished row (several threads: one at a time). The header comes with the first: its
  // names (body 0's coordinates) are known once a trajectory was set up.
  void add(long i, const BatchResult::Trajectory& row, const std::vector<std::string>& varied,
           const std::vector<std::string>& names) {
    if (path_.empty()) return;
    const std::lock_guard<std::mutex> lock(mutex_);
    if (!header_) {
      has_work_ = row.summary.has_work;
      csv_header(file_, varied, std::vector<std::string>(names.begin(), names.begin() + static_cast<std::ptrdiff_t>(row.final_q.size())),
                 has_work_, error_estimate_);
      header_ = true;
    }
    std::ostringstream line;  // whole, then one write: a kill leaves no half row
    csv_row(line, i, row, has_work_, error_estimate_);
    file_ << line.str();
    file_.flush();
  }
  void remove() {
    if (path_.empty()) return;
    file_.close();
    std::remove(path_.c_str());
  }

 private:
  std::string path_;
  std::ofstream file_;
  std::mutex mutex_;
  bool header_ = false, has_work_ = false, error_estimate_;
};

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

}  // namespace

std::string BatchResult::line() const {
  std::ostringstream os;
  os << aggregate.line() << " trajectories=" << trajectories << " threads=" << threads << " failed=" << failed;
  if (ranks > 0) os << " ranks=" << ranks;
  return os.str();
}

BatchResult run_batch(const BatchConfig& config) {
  // Only the writing process opens the output; every process journals its own rows.
  const std::string out_path = !config.processes || config.processes->writes() ? config.out : std::string();
  const bool keep_states = config.keep_states || !config.states.empty();
  if (!config.states.empty() && !is_hdf5_path(config.states))
    throw std::invalid_argument("--states " + config.states + ": the states are written as HDF5: name the file .h5");
  for (const auto& v : config.vary)
    if (keep_states && v.compare(0, 7, "bodies=") == 0)
      throw std::invalid_argument("--states with --vary bodies: the final states would differ in size; vary other "
                                  "parameters, or run one batch per size");
  if (!config.out.empty() && !is_hdf5_path(config.out) &&
      !(config.out.size() > 4 && config.out.compare(config.out.size() - 4, 4, ".csv") == 0))
    throw std::invalid_argument("--out " + config.out + ": name the file .csv (text) or .h5 / .hdf5 (HDF5)");
  const auto start = std::chrono::steady_clock::now();
  if (config.count < 1) throw std::invalid_argument("--count " + std::to_string(config.count) + ": must be at least 1");
  if (config.threads < 0) throw std::invalid_argument("--threads " + std::to_string(config.threads) + ": must be positive");
  RunConfig run_config = config.run;
  run_config.csv_path.clear();
  run_config.sink = nullptr;
  const PreparedRun prepared = prepare_run(run_config);
  Parameters base = prepared.info.defaults();
  for (const auto& a : config.run.assignments) base.assign(a);
  std::vector<Variation> variations;
  for (const auto& text : config.vary) {
    variations.push_back(parse_variation(text));
    Parameters check = base;  // the name must be one of the scene's (throws otherwise)
    check.set(variations.back().name, variations.back().lo);
  }
  std::ofstream out;
  if (!out_path.empty()) {
    out.open(out_path);
    if (!out) throw std::invalid_argument("cannot open '" + out_path + "' for writing: " + std::strerror(errno));
  }
  std::vector<std::string> varied;
  for (const auto& v : variations) varied.push_back(v.name);
  Journal journal(config.out, config.processes, config.run.error_estimate);
  // A finished row into the journal: body 0's first three coordinates (NaN where there are fewer
  // or the set-up failed), as the table shows them.
  const auto journal_row = [&](long i, const Row& row) {
    BatchResult::Trajectory r{row.values, std::vector<double>(3, std::numeric_limits<double>::quiet_NaN()), row.summary};
    for (Eigen::Index c = 0; c < std::min<Eigen::Index>(3, row.final_q.size()); ++c) r.final_q[static_cast<std::size_t>(c)] = row.final_q[c];
    if (!row.error.empty()) {
      r.summary.status = Status::InvalidInput;
      r.summary.message = row.error;
    }
    std::vector<std::string> names3 = row.names;
    if (names3.size() < 3) names3 = {"q0", "q1", "q2"};
    journal.add(i, r, varied, names3);
  };

  check_batch_memory(config);
  const int threads = batch_threads(config.threads);
  std::vector<BatchResult::Trajectory> rows;  // all of them, on the writing process only
  // Body 0's coordinate names from the set-up trajectory of lowest index: one copy, not one a row.
  std::mutex names_mutex;
  long names_from = config.count;
  std::vector<std::string> names;
  // --states: each row's whole final state, gathered into the result's arrays at the end.
  std::vector<Row> states(keep_states ? static_cast<std::size_t>(config.count) : 0);
  const auto keep = [&](long i, Row& row) {
    if (keep_states) {
      Row& s = states[static_cast<std::size_t>(i)];
      s.final_q = row.final_q;
      s.final_p = std::move(row.final_p);
      s.coordinates = std::move(row.coordinates);
      s.velocities = std::move(row.velocities);
    }
    if (!row.names.empty()) {
      const std::lock_guard<std::mutex> lock(names_mutex);
      if (i < names_from) {
        names_from = i;
        names = std::move(row.names);
      }
    }
    // The table shows at most three final coordinates: keep no more (a large model's state).
    const auto kept = std::min<Eigen::Index>(3, row.final_q.size());
    rows[static_cast<std::size_t>(i)] = {std::move(row.values),
                                         std::vector<double>(row.final_q.data(), row.final_q.data() + kept),
                                         std::move(row.summary)};
  };
  // Over several MPI ranks each sees only its own share: no bar then.
  const bool spread = config.processes && config.processes->size() > 1;
  Progress progress("batch " + prepared.info.name, spread ? 0 : config.count);
  const auto integrate_row = [&](long i, Row& row) {
    Parameters p = base;
    // Draws depend on (seed, trajectory, variation) only.
    Random random(config.seed * 0x9E3779B97F4A7C15ull + static_cast<std::uint64_t>(i));
    for (const auto& v : variations) {
      const double x = v.lo + (v.hi - v.lo) * random.uniform();
      p.set(v.name, x);
      row.values.push_back(x);
    }
    if (stop_before_start(run_config, prepared, row.summary)) {
      progress.add(1);
      return;
    }
    // The first trajectory shows the phases of its set-up until the bar replaces them.
    FinalState whole;
    row.summary = integrate_scene(prepared, p, run_config, nullptr, &row.final_q, i == 0 ? &progress : nullptr,
                                  &row.names, keep_states ? &whole : nullptr);
    if (keep_states) {
      row.final_p = std::move(whole.p);
      row.coordinates = std::move(whole.coordinates);
      row.velocities = std::move(whole.velocities);
    }
    progress.add(1);
  };
  std::vector<std::string> errors;
  if (!config.processes) {
    rows.resize(static_cast<std::size_t>(config.count));
    errors = parallel_for(config.count, threads, [&](long i, int) {
      Row row;  // a failed set-up keeps its drawn values in the table
      const std::string error = capture_error([&] { integrate_row(i, row); });
      row.error = error;
      journal_row(i, row);
      keep(i, row);
      if (!error.empty()) throw std::runtime_error(error);
    });
  } else {
    // Each row comes back as bytes, with what a failed set-up left in it (the drawn values).
    auto items = config.processes->run(config.count, threads, config.command, [&](long i, int) {
      Row row;
      row.error = capture_error([&] { integrate_row(i, row); });
      journal_row(i, row);
      return pack_row(row, keep_states);
    });
    if (!config.processes->writes()) {
      journal.remove();  // its rows reached the writing process
      BatchResult share;
      share.trajectories = config.count;
      share.threads = threads;
      share.ranks = config.processes->size();
      return share;
    }
    rows.resize(items.size());
    errors.resize(items.size());
    for (std::size_t i = 0; i < items.size(); ++i) {
      Row row;
      if (items[i].error.empty()) row = unpack_row(items[i].data);
      errors[i] = items[i].error.empty() ? row.error : items[i].error;
      if (row.values.size() != variations.size())  // the job itself failed: keep the table's columns
        row.values.assign(variations.size(), std::numeric_limits<double>::quiet_NaN());
      keep(static_cast<long>(i), row);
      items[i] = EnsembleItem{};  // the bytes are not needed twice
    }
  }
  progress.finish();

  BatchResult result;
  result.trajectories = config.count;
  result.threads = threads;
  result.ranks = config.processes ? config.processes->size() : 0;
  RunSummary& agg = result.aggregate;
  agg.scene = prepared.info.name;
  agg.method = config.run.method;
  agg.dt = prepared.dt;
  double loop_ns = 0.0;
  for (std::size_t i = 0; i < rows.size(); ++i) {
    BatchResult::Trajectory& r = rows[i];
    if (!errors[i].empty()) {
      r.summary.status = Status::InvalidInput;
      r.summary.message = std::move(errors[i]);
    }
    const RunSummary& s = r.summary;
    if (agg.backend.empty() && !s.backend.empty()) {  // the first trajectory that was set up
      agg.hitch = s.hitch;
      agg.restart = s.restart;
      agg.order = s.order;
      agg.composition = s.composition;
      agg.rotation = s.rotation;
      agg.factorizations = s.factorizations >= 0 ? 0 : -1;
      agg.stability_ratio = s.stability_ratio;
      agg.error_estimate = config.run.error_estimate ? 0.0 : std::numeric_limits<double>::quiet_NaN();
      agg.bodies = s.bodies;
      agg.backend = s.backend;
      agg.restarts = s.restarts >= 0 ? 0 : -1;
      agg.parasitic_max = std::numeric_limits<double>::quiet_NaN();
      agg.has_work = s.has_work;
      agg.work = std::numeric_limits<double>::quiet_NaN();  // a sum over trajectories means nothing
    }
    if (s.restarts > 0) agg.restarts += s.restarts;
    agg.legendre_iterations_max = std::max(agg.legendre_iterations_max, s.legendre_iterations_max);
    if (!std::isnan(s.stability_ratio)) agg.stability_ratio = worst(agg.stability_ratio, s.stability_ratio);
    if (agg.warning.empty() && !s.warning.empty()) agg.warning = "trajectory " + std::to_string(i) + ": " + s.warning;
    if (!std::isnan(s.parasitic_max) && !(s.parasitic_max <= agg.parasitic_max)) {
      agg.parasitic_max = s.parasitic_max;
      if (!s.warning.empty()) agg.warning = "trajectory " + std::to_string(i) + ": " + s.warning;
    }
    agg.energy_balance_err_max = worst(agg.energy_balance_err_max, s.energy_balance_err_max);
    if (s.status != Status::Ok) {
      if (result.failed++ == 0) result.first_failure = "trajectory " + std::to_string(i) + ": " + s.message;
      if (s.status == Status::Inaccurate) ++result.inaccurate;
      agg.status = s.status;
    }
    agg.steps += s.steps;
    agg.t_final = std::max(agg.t_final, s.t_final);
    loop_ns += s.ns_per_step * static_cast<double>(s.steps);
    agg.energy_rel_err_max = worst(agg.energy_rel_err_max, s.energy_rel_err_max);
    agg.energy_post_rel_err_max = worst(agg.energy_post_rel_err_max, s.energy_post_rel_err_max);
    agg.residual_max = worst(agg.residual_max, s.residual_max);
    agg.residual_rel_max = worst(agg.residual_rel_max, s.residual_rel_max);
    agg.gap_max = worst(agg.gap_max, s.gap_max);
    agg.has_momentum = s.has_momentum;
    agg.has_error_estimate = s.has_error_estimate;
    agg.momentum_drift_max = worst(agg.momentum_drift_max, s.momentum_drift_max);
    if (s.factorizations >= 0 && agg.factorizations >= 0) agg.factorizations += s.factorizations;
    // NaN (a companion that failed) wins: the estimate is then unknown.
    if (config.run.error_estimate && !(s.error_estimate <= agg.error_estimate)) agg.error_estimate = s.error_estimate;
    if (s.rhs_evaluations >= 0) agg.rhs_evaluations = std::max(0L, agg.rhs_evaluations) + s.rhs_evaluations;
  }
  agg.ns_per_step = agg.steps > 0 ? loop_ns / static_cast<double>(agg.steps) : 0.0;
  agg.ns_per_body_step = agg.bodies > 0 ? agg.ns_per_step / agg.bodies : 0.0;

  // The columns: varied parameters, final time, body 0's coordinates, the errors. The names
  // come from a trajectory that was set up (no model is built again just for them: a large
  // one takes seconds); if none was, from the fixed parameters alone.
  if (names.empty()) {
    names = {"q0", "q1", "q2"};
    try {
      names = prepared.info.build(base).model.coordinate_names();
    } catch (const std::exception&) {  // the fixed parameters alone are not a valid scene
    }
  }
  const std::size_t shown = std::min<std::size_t>(3, names.size());
  result.varied = varied;
  result.shown.assign(names.begin(), names.begin() + static_cast<std::ptrdiff_t>(shown));
  for (BatchResult::Trajectory& r : rows) r.final_q.resize(shown, std::numeric_limits<double>::quiet_NaN());
  result.rows = std::move(rows);
  if (keep_states) gather_states(states, result.states);

  if (out.is_open()) {  // CSV, or HDF5 by the extension (hdf5_output.hpp)
    if (is_hdf5_path(out_path)) {
      out.close();  // it only checked that the path is writable, before integrating
      BatchConfig used = config;
      used.run.dt = prepared.dt;
      used.run.t_end = prepared.t_end;
      write_batch_hdf5(out_path, used, prepared.info.name, result, prepared.steps);
    } else {
      write_batch_csv(out, out_path, result, config.run.error_estimate);
    }
  }
  if (!config.states.empty() && (!config.processes || config.processes->writes())) {
    BatchConfig used = config;
    used.run.dt = prepared.dt;
    used.run.t_end = prepared.t_end;
    write_batch_states(config.states, used, prepared.info.name, result, prepared.steps);
  }
  journal.remove();
  agg.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return result;
}

}  // namespace nonholo::scenarios
