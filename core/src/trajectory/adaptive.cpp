// Adaptive composed steps (adaptive.hpp): a pair of steps judged by step doubling, the
// error-per-unit-step test and the step-size controller.
#include <nonholo/adaptive.hpp>

#include <nonholo/rattle.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>

namespace nonholo {
namespace {

[[noreturn]] void reject(const char* what, double value, const char* rule) {
  std::ostringstream os;
  os << "AdaptiveOptions: " << what << " = " << value << " " << rule;
  throw std::invalid_argument(os.str());
}

// The round-off floor of a doubling difference, in units of eps (|q| + (horizon / 2) |v|), at
// first; raised where a run shows more (AdaptiveStepper::round_off_).
constexpr double kNoise = 64.0 * std::numeric_limits<double>::epsilon();
// The local error allowed per unit step, in units of tol / horizon: the errors of the symmetric
// compositions add up to less than their local errors' sum (docs/guide/methods.md "Adaptive steps").
constexpr double kBudget = 10.0;

}  // namespace

void validate(const AdaptiveOptions& o) {
  if (!(o.tol > 0.0 && o.tol < 1.0)) reject("tol", o.tol, "must lie in (0, 1)");
  if (!(o.horizon > 0.0) || !std::isfinite(o.horizon)) reject("horizon", o.horizon, "must be positive and finite");
  if (!(o.h_initial > 0.0) || !std::isfinite(o.h_initial)) reject("h_initial", o.h_initial, "must be positive and finite");
  if (!(o.h_min > 0.0) || !(o.h_min <= o.h_initial)) reject("h_min", o.h_min, "must be positive and at most h_initial");
  if (!(o.h_max >= o.h_initial)) reject("h_max", o.h_max, "must be at least h_initial");
  if (!(o.safety > 0.0 && o.safety <= 1.0)) reject("safety", o.safety, "must lie in (0, 1]");
  if (!(o.min_factor > 0.0 && o.min_factor < 1.0)) reject("min_factor", o.min_factor, "must lie in (0, 1)");
  if (!(o.max_factor > 1.0) || !std::isfinite(o.max_factor)) reject("max_factor", o.max_factor, "must be above 1 and finite");
}

AdaptiveStepper::AdaptiveStepper(const Model& model, const RattleOptions& options, const AdaptiveOptions& adaptive)
    : options_(options), adaptive_(adaptive), order_(options.order), h_(adaptive.h_initial) {
  validate(adaptive);
  if (order_ != 2 && order_ != 4 && order_ != 6 && order_ != 8) {
    std::ostringstream os;
    os << "adaptive steps: order = " << order_ << " must be 2, 4, 6 or 8";
    throw std::invalid_argument(os.str());
  }
  // The plain step carries lambda~ from one step to the next, which a change of h would
  // misplace: restart it at every step, as the composed steps do at theirs (the energy-exact
  // restart keeps the order, 2).
  if (order_ == 2) {
    options_.restart.mode = RestartMode::Periodic;
    options_.restart.every = 1;
  }
  options_.h = adaptive.h_initial;
  validate(options_);
  const Eigen::Index nq = model.num_configuration(), nv = model.num_velocities(), m = model.num_one_forms();
  velocity_.setZero(nv);
  difference_.setZero(nv);
  for (State* s : {&saved_, &shadow_}) {
    s->q.setZero(nq);
    s->p.setZero(nv);
    s->force.setZero(nv);
    s->lambda.setZero(m);
  }
}

void AdaptiveStepper::reset() {
  h_ = adaptive_.h_initial;
  starting_ = true;
}

// |dq| + (horizon / 2) |dv| between the pair's end and the shadow's, and its round-off floor
// 64 eps (|q| + (horizon / 2) |v|).
double AdaptiveStepper::doubling_error(const Model& model, const State& pair, const State& shadow, double& noise) {
  const double lever = 0.5 * adaptive_.horizon;
  difference_ = shadow.p - pair.p;
  model.inverse_mass().multiply(difference_.data(), velocity_.data());
  const double dv = velocity_.lpNorm<Eigen::Infinity>();
  model.inverse_mass().multiply(pair.p.data(), velocity_.data());
  noise = kNoise * (pair.q.lpNorm<Eigen::Infinity>() + lever * velocity_.lpNorm<Eigen::Infinity>());
  return (shadow.q - pair.q).lpNorm<Eigen::Infinity>() + lever * dv;
}

Status AdaptiveStepper::step(const Model& model, Workspace& ws, State& s, double t_stop) {
  if (!(t_stop > s.t))
    return ws.fail(Status::InvalidStepSize, "adaptive step: t_stop = %.17g is not after t = %.17g", t_stop, s.t);
  saved_ = s;  // same sizes: a copy, no allocation
  const double rate = kBudget * adaptive_.tol / adaptive_.horizon;
  const double doubling = std::ldexp(1.0, order_ + 1) - 2.0;  // the shadow's difference over the local error
  double rejected_d = 0.0, rejected_h = 0.0;  // the last rejected attempt from saved_
  for (;;) {
    // Land on t_stop rather than pass it: the last pair splits what is left in two.
    const double left = t_stop - s.t;
    double h = std::min(h_, adaptive_.h_max);
    const bool landing = 2.0 * h >= left * (1.0 - 1e-12);
    if (landing) h = 0.5 * left;
    options_.h = h;
    Status status = nonholo::step(model, ws, s, options_);
    if (status == Status::Ok) {
      options_.h = landing ? t_stop - s.t : h;  // the second step ends at t_stop exactly
      status = nonholo::step(model, ws, s, options_);
    }
    double factor = 0.25;  // a failed composed step is retried 4 times smaller
    bool accept = false;
    if (status == Status::Ok) {
      shadow_ = saved_;
      options_.h = s.t - saved_.t;
      const Status shadow = nonholo::step(model, ws, shadow_, options_);
      double noise = 0.0;
      const double d = shadow == Status::Ok ? doubling_error(model, s, shadow_, noise) : 0.0;
      if (shadow != Status::Ok) {
        // The step of 2h failed where two of h did not: judge the pair by shrinking it.
        factor = 0.5;
      } else {
        // In units of d: the budget, or the round-off floor where the tolerance asks for less
        // than round-off resolves (there the step settles where d meets the floor).
        const double floor = noise * round_off_;
        const bool below_round_off = doubling * rate * h <= floor;
        const double allowed = below_round_off ? floor : doubling * rate * h;
        if (d <= floor) {
          // Too small to see: accept and grow (slowly where the floor is the limit).
          accept = true;
          factor = below_round_off ? 1.25 : std::numeric_limits<double>::infinity();
        } else if (below_round_off && d <= 8.0 * floor) {
          // The tolerance asks for less than round-off resolves: shorter steps would only add
          // round-off. Accept near the floor; settle where d meets it.
          accept = true;
          factor = adaptive_.safety * std::pow(floor / d, 1.0 / order_);
        } else if (rejected_h > 0.0 && d < 1e3 * floor && d > 4.0 * rejected_d * std::pow(h / rejected_h, order_ + 1)) {
          // Retried shorter, the difference did not fall as a local error of order p + 1 must:
          // it is round-off above the floor assumed. Accept, hold the step, raise the floor.
          accept = true;
          factor = 1.0;
          round_off_ = std::max(round_off_, 2.0 * d / noise);
        } else {
          estimate_ = d / doubling;
          accept = d <= allowed;
          factor = adaptive_.safety * std::pow(allowed / d, 1.0 / order_);
          if (!accept) rejected_d = d, rejected_h = h;
        }
      }
    }
    // Until the controller first asks for less than the fastest growth, h_initial was too small:
    // let the pairs grow 4 times faster (each is judged like any other).
    if (factor < adaptive_.max_factor) starting_ = false;
    factor = std::clamp(factor, adaptive_.min_factor, (starting_ ? 4.0 : 1.0) * adaptive_.max_factor);
    if (accept) {
      accepted_ += 2;
      last_h_ = h;
      // A landing pair (shortened) keeps the controller's size unless its estimate asks for less.
      if (!landing)
        h_ = h * factor;
      else if (factor < 1.0)
        h_ = std::min(h_, h * factor);
      return Status::Ok;
    }
    ++rejected_;
    s = saved_;
    h_ = h * factor;
    if (h_ < adaptive_.h_min)
      return ws.fail(Status::StepSizeTooSmall,
                     "adaptive step at t = %.17g: the error test failed down to H = %.3g, below h_min = %.3g (the "
                     "last attempt: %s)",
                     s.t, h_, adaptive_.h_min, status == Status::Ok ? "estimate too large" : to_string(status));
  }
}

void AdaptiveStepper::save(OutArchive& a) const {
  a.tag("adaptive");
  a(order_), a(adaptive_.tol), a(adaptive_.horizon);
  a(h_), a(last_h_), a(accepted_), a(rejected_), a(starting_), a(round_off_), a(estimate_);
}

void AdaptiveStepper::load(InArchive& a) {
  a.tag("adaptive");
  int order = 0;
  double tol = 0.0, horizon = 0.0;
  a(order), a(tol), a(horizon);
  if (order != order_ || tol != adaptive_.tol || horizon != adaptive_.horizon) {
    std::ostringstream os;
    os.precision(17);
    os << "checkpoint: adaptive steps of order " << order << ", tol " << tol << " over " << horizon
       << "; this run's are of order " << order_ << ", tol " << adaptive_.tol << " over " << adaptive_.horizon;
    throw std::runtime_error(os.str());
  }
  a(h_), a(last_h_), a(accepted_), a(rejected_), a(starting_), a(round_off_), a(estimate_);
}

}  // namespace nonholo
