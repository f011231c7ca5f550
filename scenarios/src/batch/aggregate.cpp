// A batch's summary line from its trajectories' (aggregate.hpp): errors and energies at their
// worst, steps, restarts and factorisations summed, the per-step time weighted by the steps, the
// set-up per trajectory.
#include "batch/aggregate.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace nonholo::scenarios {
namespace {

// The fields the first trajectory that was set up gives the whole batch (its backend, order, ...),
// and the sums and maxima started from there.
void start_from(const RunSummary& s, const BatchConfig& config, RunSummary& agg) {
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

}  // namespace

void aggregate(const PreparedRun& prepared, const BatchConfig& config, std::vector<BatchResult::Trajectory>& rows,
               std::vector<std::string>& errors, BatchResult& result) {
  RunSummary& agg = result.aggregate;
  agg.scene = prepared.info.name;
  agg.method = config.run.method;
  agg.dt = prepared.dt;
  double loop_ns = 0.0, setup_s = 0.0;
  for (std::size_t i = 0; i < rows.size(); ++i) {
    BatchResult::Trajectory& r = rows[i];
    if (!errors[i].empty()) {
      r.summary.status = Status::InvalidInput;
      r.summary.message = std::move(errors[i]);
    }
    const RunSummary& s = r.summary;
    if (agg.backend.empty() && !s.backend.empty()) start_from(s, config, agg);  // the first set up
    if (s.restarts > 0) agg.restarts += s.restarts;
    agg.legendre_iterations_max = std::max(agg.legendre_iterations_max, s.legendre_iterations_max);
    if (!std::isnan(s.stability_ratio)) agg.stability_ratio = worst(agg.stability_ratio, s.stability_ratio);
    if (agg.warning.empty() && !s.warning.empty()) agg.warning = "trajectory " + std::to_string(i) + ": " + s.warning;
    for (const RunWarning& w : s.warnings) {  // each kind once: the first trajectory's
      auto same = [&w](const RunWarning& seen) { return seen.kind == w.kind; };
      if (std::none_of(agg.warnings.begin(), agg.warnings.end(), same))
        agg.warnings.push_back({w.kind, "trajectory " + std::to_string(i) + ": " + w.text});
    }
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
    setup_s += s.setup_s;
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
  agg.setup_s = rows.empty() ? 0.0 : setup_s / static_cast<double>(rows.size());
  agg.ns_per_body_step = agg.bodies > 0 ? agg.ns_per_step / agg.bodies : 0.0;
}

}  // namespace nonholo::scenarios
