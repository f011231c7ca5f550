// What a run's end says about it: the accuracy check's verdict (status=inaccurate) and the
// warnings of a run that ended ok (the period-2 mode, step sizes capped by the output interval).
#include "run/verdicts.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <string>

namespace nonholo::scenarios {

// The accuracy check's verdict on a run that ended ok: status=inaccurate when the estimated error
// exceeds the tolerance, a fraction of the motion's extent. The advice: the step that would meet
// the tolerance if the error falls as dt^p, with a factor 2 to spare.
void judge_accuracy(RunSummary& summary, const RunConfig& config, int order, const DoublingEstimate& watch,
                    bool has_orders) {
  const double largest_coordinate = watch.largest_coordinate();
  if (summary.status != Status::Ok || !(config.accuracy > 0.0) || std::isnan(summary.extent)) return;
  summary.accuracy = config.accuracy;
  // Every sample's step of 2 dt failed: nothing was compared, so nothing vouches for the result
  // (veselova at dt 0.6 ended ok with error_estimate=0, 44-72 % of its extent off). Not ok.
  if (watch.samples() == 0 && watch.failed_samples() > 0) {
    std::ostringstream os;
    os.precision(3);
    summary.status = Status::Inaccurate;
    summary.error_estimate = std::numeric_limits<double>::quiet_NaN();
    const long failed = watch.failed_samples();
    os << "the accuracy check took no sample: its step of 2 dt failed "
       << (failed == 1 ? std::string("once") : std::to_string(failed) + " times") << " (first at " << watch.first_failure() << "), so nothing judged the result; a step that fails at "
       << "2 dt = " << 2.0 * summary.dt << " leaves dt = " << summary.dt << " within a factor 2 of what the method "
       << "can take: use --dt " << 0.5 * summary.dt << " or smaller. The results are written; --accuracy 0 "
       << "accepts them unjudged";
    summary.message = os.str();
    return;
  }
  // Step doubling needs the step of 2 dt to be stable: from half the stability limit on, the
  // shadow's error is that of an unstable step, not a measure of the run's (a stiff spring chain
  // at 0.965 of the limit: estimate 11 where the error is 0.003). The stability warning says
  // what to do there.
  if (summary.stability_ratio >= 0.5) return;
  // A motion with no extent (a body at rest) is judged against round-off instead.
  const double allowed = std::max(config.accuracy * summary.extent,
                                  64 * std::numeric_limits<double>::epsilon() * largest_coordinate);
  const double e = summary.error_estimate;
  if (!(e > allowed) && !std::isnan(e)) return;
  std::ostringstream os;
  os.precision(3);
  summary.status = Status::Inaccurate;
  os << "the estimated error in q, " << e << ", is " << e / summary.extent << " of the motion's extent "
     << summary.extent << " (the widest range a coordinate swept), above --accuracy " << config.accuracy << ": ";
  const double suggested = summary.dt * 0.5 * std::pow(allowed / e, 1.0 / order);
  if (watch.transient_samples() > 0)
    os << "the step does not resolve a transient (from t = " << watch.first_transient()
       << ", a step of 2 dt and two of dt differ by more than 1 % of the speed): its error falls more slowly than "
          "dt^"
       << order << "; reduce --dt tenfold or more and compare error_estimate";
  else if (std::isfinite(suggested) && suggested > 0.0)
    os << "the step is too large for this motion; use --dt " << suggested << " or smaller (an order-" << order
       << " method's error falls as dt^" << order << ")" << (has_orders ? ", or a higher --order" : "");
  else
    os << "the step is too large for this motion: reduce --dt";
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

void add_warning(RunSummary& summary, const std::string& warning) {
  if (!warning.empty()) summary.warning += (summary.warning.empty() ? "" : " ") + warning;
}

}  // namespace nonholo::scenarios
