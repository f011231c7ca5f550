// The summary line (RunSummary::fields() and line()): which keys a run shows, in their order,
// and how they print. docs/reference/summary.md explains each key.
#include <nonholo/scenarios/run_types.hpp>

#include <cmath>
#include <sstream>
#include <string>
#include <vector>

namespace nonholo::scenarios {

const char* to_string(WarningKind kind) {
  switch (kind) {
    case WarningKind::Accuracy: return "accuracy";
    case WarningKind::Stability: return "stability";
    case WarningKind::Precision: return "precision";
    case WarningKind::Method: return "method";
    case WarningKind::Performance: return "performance";
  }
  return "unknown";
}

std::vector<SummaryField> RunSummary::fields() const {
  std::vector<SummaryField> f;
  auto text = [&f](const char* key, const std::string& value) { f.push_back({key, SummaryField::Text, 0.0, 0, value}); };
  auto number = [&f](const char* key, double value) { f.push_back({key, SummaryField::Number, value, 0, {}}); };
  auto integer = [&f](const char* key, long value) { f.push_back({key, SummaryField::Integer, 0.0, value, {}}); };
  text("scene", scene);
  text("method", method);
  text("hitch", hitch);
  if (order > 0) integer("order", order);
  if (!composition.empty()) text("composition", composition);
  if (!rotation.empty()) text("rotation", rotation);
  if (!restart.empty()) text("restart", restart);
  integer("bodies", bodies);
  integer("steps", steps);
  number("dt", dt);
  number("t_end", t_final);
  number("wall_s", wall_s);
  number("setup_s", setup_s);
  number("ns_per_step", ns_per_step);
  number("ns_per_body_step", ns_per_body_step);
  number("energy_rel_err_max", energy_rel_err_max);
  if (has_work) {
    number("energy_balance_err_max", energy_balance_err_max);
    if (!std::isnan(work)) number("work", work);
  } else {
    number("energy_post_rel_err_max", energy_post_rel_err_max);
  }
  number("residual_max", residual_max);
  number("residual_rel_max", residual_rel_max);
  number("gap_max", gap_max);
  if (restarts >= 0) {
    integer("restarts", restarts);
    number("parasitic_max", parasitic_max);
  }
  if (has_momentum) number("momentum_drift_max", momentum_drift_max);
  if (legendre_iterations_max >= 0) integer("legendre_iterations_max", legendre_iterations_max);
  if (adaptive_steps >= 0) {
    number("tol", tol);
    integer("adaptive_steps", adaptive_steps);
    integer("rejected", rejected);
  }
  if (rhs_evaluations >= 0) integer("rhs_evals", rhs_evaluations);
  if (factorizations >= 0) integer("factorizations", factorizations);
  if (has_error_estimate || !std::isnan(error_estimate)) number("error_estimate", error_estimate);
  if (!std::isnan(extent)) number("extent", extent);
  if (!accuracy_check.empty()) text("accuracy_check", accuracy_check);
  if (!std::isnan(stability_ratio)) number("stability_ratio", stability_ratio);
  if (!stopped_by.empty()) {
    text("stopped_by", stopped_by);
    number("t_stop", t_stop);
  }
  text("backend", backend);
  if (threads > 0) integer("threads", threads);
  if (!warnings.empty()) {  // the kinds, each once, in the order they came
    std::string kinds;
    for (const RunWarning& w : warnings) {
      const std::string kind = to_string(w.kind);
      if (("," + kinds + ",").find("," + kind + ",") == std::string::npos) kinds += (kinds.empty() ? "" : ",") + kind;
    }
    text("warnings", kinds);
  }
  text("status", to_string(status));
  return f;
}

std::string RunSummary::line() const {
  std::ostringstream os;
  os.precision(6);
  const char* separator = "";
  for (const SummaryField& field : fields()) {
    os << separator << field.key << '=';
    separator = " ";
    if (field.kind == SummaryField::Number)
      os << field.number;
    else if (field.kind == SummaryField::Integer)
      os << field.integer;
    else
      os << field.text;
  }
  return os.str();
}

}  // namespace nonholo::scenarios
