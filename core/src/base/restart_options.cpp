// Parsing and checking of RestartOptions (restart_options.hpp).
#include <nonholo/restart_options.hpp>

#include <cmath>
#include <stdexcept>

#include "base/option_checks.hpp"

namespace nonholo {

const char* to_string(RestartMode mode) {
  switch (mode) {
    case RestartMode::Never: return "never";
    case RestartMode::Periodic: return "periodic";
    case RestartMode::Auto: return "auto";
  }
  return "unknown";
}

namespace detail {

OptionProblem restart_problem(const RestartOptions& o) {
  if (o.mode == RestartMode::Periodic && o.every < 1)
    return {"restart every", static_cast<double>(o.every), "must be at least 1 with RestartMode::Periodic"};
  if (o.every < 0) return {"restart every", static_cast<double>(o.every), "must not be negative"};
  if (!(o.tolerance >= 0.0) || !std::isfinite(o.tolerance))
    return {"restart tolerance", o.tolerance, "must be 0 (h^3) or positive and finite"};
  if (o.monitor_every < 0)
    return {"monitor_every", static_cast<double>(o.monitor_every), "must be 0 (never) or positive"};
  if (o.mode == RestartMode::Auto && o.monitor_every < 1)
    return {"monitor_every", static_cast<double>(o.monitor_every), "must be at least 1 with RestartMode::Auto"};
  return {};
}

}  // namespace detail

void validate(const RestartOptions& o) { detail::reject_if(detail::restart_problem(o)); }

void set_restart(RestartOptions& o, const std::string& spec) {
  if (spec == "auto") {
    o.mode = RestartMode::Auto;
    return;
  }
  if (spec == "0" || spec == "never") {
    o.mode = RestartMode::Never;
    return;
  }
  long k = 0;
  std::size_t used = 0;
  try {
    k = std::stol(spec, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used != spec.size() || used == 0 || k < 1 || k > 1000000000L)
    throw std::invalid_argument("restart '" + spec +
                                "': expected auto, 0 (never) or a number of steps K from 1 to 1e9");
  o.mode = RestartMode::Periodic;
  o.every = static_cast<int>(k);
}

std::string restart_spec(const RestartOptions& o) {
  switch (o.mode) {
    case RestartMode::Never: return "0";
    case RestartMode::Periodic: return std::to_string(o.every);
    case RestartMode::Auto: return "auto";
  }
  return "unknown";
}

}  // namespace nonholo
