// What a run's end says about it: the accuracy check's verdict (status=inaccurate) and the
// warnings of a run that ended ok (the period-2 mode, step sizes capped by the output interval).
#include "run/verdicts.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <string>

namespace nonholo::scenarios {

namespace {

// No comparison vouches for the result: not ok (veselova at dt 0.6, whose every step of 2 dt
// failed, ended ok with error_estimate=0, 44-72 % of its extent off).
void nothing_judged(RunSummary& summary, const DoublingEstimate& watch) {
  std::ostringstream os;
  os.precision(3);
  summary.status = Status::Inaccurate;
  summary.error_estimate = std::numeric_limits<double>::quiet_NaN();
  const long failed = watch.failed_samples();
  os << "the accuracy check took no sample: its step of 2 dt failed "
     << (failed == 1 ? std::string("once") : std::to_string(failed) + " times") << " (first at "
     << watch.first_failure() << "), so nothing judged the result; a step that fails at 2 dt = " << 2.0 * summary.dt
     << " leaves dt = " << summary.dt << " within a factor 2 of what the method can take: use --dt "
     << 0.5 * summary.dt << " or smaller. The results are written; --accuracy 0 accepts them unjudged";
  summary.message = os.str();
}

}  // namespace

// The accuracy check's verdict on a run that ended ok: status=inaccurate when the estimated error
// exceeds the tolerance, a fraction of the motion's extent (adaptive steps: or 10 tol). The advice:
// the step that would meet the tolerance if the error falls as dt^p, with a factor 2 to spare
// (adaptive steps: the tol, their error being about in proportion to it).
void judge_accuracy(RunSummary& summary, const RunConfig& config, int order, const DoublingEstimate* watch,
                    double largest_coordinate, bool has_orders) {
  if (watch) largest_coordinate = watch->largest_coordinate();
  if (summary.status != Status::Ok || !(config.accuracy > 0.0) || std::isnan(summary.extent)) return;
  summary.accuracy = config.accuracy;
  const bool sampled = summary.accuracy_check == "sampled";
  if (sampled && watch && watch->samples() == 0 && watch->failed_samples() > 0) return nothing_judged(summary, *watch);
  // Step doubling and the companion need the step of 2 dt to be stable: from half the stability
  // limit on, its error is that of an unstable step, not a measure of the run's (a stiff spring
  // chain at 0.965 of the limit: estimate 11 where the error is 0.003). The stability warning says
  // what to do there.
  if (summary.stability_ratio >= 0.5) return;
  // A motion with no extent (a body at rest) is judged against round-off instead.
  const double of_extent = std::max(config.accuracy * summary.extent,
                                    64 * std::numeric_limits<double>::epsilon() * largest_coordinate);
  const bool adaptive = config.adaptive;
  const double allowed = adaptive ? std::min(of_extent, 10.0 * config.tol) : of_extent;
  const double e = summary.error_estimate;
  if (!(e > allowed) && !std::isnan(e)) return;
  std::ostringstream os;
  os.precision(3);
  summary.status = Status::Inaccurate;
  os << "the estimated error in q, " << e << ", is " << e / summary.extent << " of the motion's extent "
     << summary.extent << " (the widest range a coordinate swept)";
  if (adaptive && allowed < of_extent)
    os << ", more than 10 times --tol " << config.tol << ": ";
  else
    os << ", above --accuracy " << config.accuracy << ": ";
  if (adaptive) {
    // Their error is about in proportion to tol, at a ratio the motion sets (a fast chain: 14-22
    // times at tol 1e-6 to 1e-3, order 4): a smaller tol gives a smaller error, not a better ratio.
    const double ratio = e / config.tol;
    os << "the adaptive steps' error here is " << ratio << " times their --tol (their budget assumes errors that do "
       << "not grow); it falls about in proportion to --tol: for an error near " << config.tol << " use --tol "
       << config.tol / ratio << " (judged the same way)";
  } else if (watch && watch->transient_samples() > 0) {
    os << "the step does not resolve a transient (from t = " << watch->first_transient()
       << ", a step of 2 dt and two of dt differ by more than 1 % of the speed): its error falls more slowly than "
          "dt^"
       << order << "; reduce --dt tenfold or more and compare error_estimate";
  } else {
    const double suggested = summary.dt * 0.5 * std::pow(allowed / e, 1.0 / order);
    if (std::isfinite(suggested) && suggested > 0.0)
      os << "the step is too large for this motion; use --dt " << suggested << " or smaller (an order-" << order
         << " method's error falls as dt^" << order << ")" << (has_orders ? ", or a higher --order" : "");
    else
      os << "the step is too large for this motion: reduce --dt";
  }
  os << ". The results are written; --accuracy 0 turns the check off";
  summary.message = os.str();
}

std::string parasitic_warning(const RunSummary& r, const RattleOptions& o) {
  std::ostringstream os;
  os.precision(3);
  os << "the period-2 mode reached " << r.parasitic_max << " of the momentum (parasitic_max): the velocities and "
     << "the trajectory are off by about that much. ";
  // Above 1 despite the restarts, the continuous multiplier lambda_s(p~), quadratic in the
  // velocity, kicks the momentum by more than itself in half a step: a speed or turn rate beyond
  // what the step can follow (a sleigh at v0 = 1e4 damps its turn at 1900/s; at h = 0.01 the
  // discrete turn reached 8000 rad/s). Without restarts the mode itself grows that far.
  if (r.parasitic_max >= 1.0 && o.restart.mode == RestartMode::Auto) {
    os << "Above 1 the step cannot follow the motion: the constraint force that p~'s velocity needs turns the "
       << "momentum by more than a radian per step (a speed or a turn rate h|omega| too large for dt = " << o.h
       << "); use --dt " << o.h * std::cbrt(kParasiticWarning / (2.0 * r.parasitic_max))
       << " or smaller (the mode's seed falls as dt^3).";
    return os.str();
  }
  // Holonomic hitches close each gap within one step: a gap of g (round-off of |q| once the
  // step is tiny) becomes a velocity kick 2 g / dt, which seeds the mode no smaller step removes.
  const double speed = r.extent / (static_cast<double>(r.steps) * r.dt);  // the motion's scale
  const double kick = 2.0 * r.gap_max / r.dt;
  if (r.hitch == "holonomic" && speed > 0.0 && std::isfinite(speed) && kick > kGapKick * speed) {
    os << "The hitches' gap corrections dominate: closing gaps of up to " << r.gap_max << " (gap_max, round-off "
       << "of the coordinates) within one step of dt = " << r.dt << " kicks the velocities by up to " << kick
       << " against a motion of about " << speed << " per unit time; use --hitch oneform, or --dt "
       << 2.0 * r.gap_max / (kGapKick * speed) << " or larger.";
    return os.str();
  }
  if (o.restart.mode != RestartMode::Auto)
    os << "Use --restart auto (energy-exact restarts when needed).";
  else
    os << "Steps excite the mode faster than the restarts remove it (" << r.restarts << " restarts in " << r.steps
       << " steps, tolerance " << o.restart.tolerance_for(o.h)
       << "): the step is too large for the motion: reduce --dt (the mode's seed falls as dt^3).";
  return os.str();
}

// What to change when the energy blew up: a grown period-2 mode needs restarts (a smaller step
// does not help it), anything else a smaller step.
std::string energy_advice(const RunSummary& r, const RattleOptions& o) {
  return r.parasitic_max > kParasiticWarning ? parasitic_warning(r, o) : "reduce --dt";
}

void add_warning(RunSummary& summary, WarningKind kind, const std::string& warning) {
  if (warning.empty()) return;
  summary.warning += (summary.warning.empty() ? "" : " ") + warning;
  summary.warnings.push_back({kind, warning});
}

}  // namespace nonholo::scenarios
