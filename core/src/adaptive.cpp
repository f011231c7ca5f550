// Adaptive composed steps (adaptive.hpp): the Milne-device estimate from the configurations of
// the last accepted steps, the error-per-unit-step test and the step-size controller.
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

// kappa of adaptive.hpp by order: the estimate of a step is this many times tol H where the
// error at the end of a run is about tol (README "Adaptive steps": measured on the sleigh to
// t = 10 and the 10- and 100-body chains to t = 100; order 8 is not proportional, see there).
double kappa(int order) {
  switch (order) {
    case 4: return 1e3;
    case 6: return 1e4;
    default: return 1e5;
  }
}

}  // namespace

void validate(const AdaptiveOptions& o) {
  if (!(o.tol > 0.0 && o.tol < 1.0)) reject("tol", o.tol, "must lie in (0, 1)");
  if (!(o.h_initial > 0.0) || !std::isfinite(o.h_initial)) reject("h_initial", o.h_initial, "must be positive and finite");
  if (!(o.h_min > 0.0) || !(o.h_min <= o.h_initial)) reject("h_min", o.h_min, "must be positive and at most h_initial");
  if (!(o.h_max >= o.h_initial)) reject("h_max", o.h_max, "must be at least h_initial");
  if (!(o.safety > 0.0 && o.safety <= 1.0)) reject("safety", o.safety, "must lie in (0, 1]");
  if (!(o.min_factor > 0.0 && o.min_factor < 1.0)) reject("min_factor", o.min_factor, "must lie in (0, 1)");
  if (!(o.max_factor > 1.0) || !std::isfinite(o.max_factor)) reject("max_factor", o.max_factor, "must be above 1 and finite");
}

AdaptiveStepper::AdaptiveStepper(const Model& model, const RattleOptions& options, const AdaptiveOptions& adaptive)
    : options_(options), adaptive_(adaptive), order_(options.order), points_(options.order + 1),
      h_(adaptive.h_initial) {
  validate(adaptive);
  if (order_ != 4 && order_ != 6 && order_ != 8) {
    std::ostringstream os;
    os << "adaptive steps need a composed step: order = " << order_ << " must be 4, 6 or 8";
    throw std::invalid_argument(os.str());
  }
  options_.h = adaptive.h_initial;
  validate(options_);
  const int n = model.num_velocities();
  history_.setZero(model.num_configuration(), points_);
  times_.setZero(points_);
  predicted_.setZero(model.num_configuration());
  saved_.q.setZero(model.num_configuration());
  saved_.p.setZero(n);
  saved_.force.setZero(n);
  saved_.lambda.setZero(model.num_one_forms());
}

void AdaptiveStepper::reset() {
  count_ = head_ = 0;
  h_ = adaptive_.h_initial;
}

// The Lagrange polynomial through the history's (t_i, q_i), at t; and the round-off that its
// weights w_i amplify (64 eps sum |w_i| |q|_inf), below which the difference says nothing.
double AdaptiveStepper::extrapolation_error(double t, ConstVecRef q, double& noise) {
  predicted_.setZero();
  double weights = 0.0;
  for (int i = 0; i < points_; ++i) {
    double w = 1.0;
    for (int j = 0; j < points_; ++j)
      if (j != i) w *= (t - times_[j]) / (times_[i] - times_[j]);
    predicted_ += w * history_.col(i);
    weights += std::abs(w);
  }
  noise = 64.0 * std::numeric_limits<double>::epsilon() * weights * q.lpNorm<Eigen::Infinity>();
  return (q - predicted_).lpNorm<Eigen::Infinity>();
}

Status AdaptiveStepper::step(const Model& model, Workspace& ws, State& s, double t_stop) {
  if (!(t_stop > s.t))
    return ws.fail(Status::InvalidStepSize, "adaptive step: t_stop = %.17g is not after t = %.17g", t_stop, s.t);
  saved_ = s;  // same sizes: a copy, no allocation
  const double limit = kappa(order_) * adaptive_.tol;
  for (;;) {
    const bool estimated = count_ == points_;
    // Land on t_stop rather than pass it; split what is left in two rather than leave a sliver.
    const double left = t_stop - s.t;
    double h = std::min(h_, adaptive_.h_max);
    const bool landing = h >= left * (1.0 - 1e-12);
    if (landing)
      h = left;
    else if (h > 0.5 * left)
      h = 0.5 * left;
    options_.h = h;
    const Status status = nonholo::step(model, ws, s, options_);
    double factor = 0.25;  // a failed composed step is retried 4 times smaller
    bool accept = false;
    if (status == Status::Ok) {
      if (!estimated) {
        accept = true;
        factor = 1.0;
      } else {
        double noise = 0.0;
        const double e = extrapolation_error(s.t, s.q, noise);
        // At the round-off floor the estimate cannot tell: accept, and grow slowly (the history
        // follows); above it, the controller.
        accept = e <= std::max(limit * h, noise);
        factor = e <= noise ? 1.25 : adaptive_.safety * std::pow(limit * h / e, 1.0 / order_);
        factor = std::clamp(factor, adaptive_.min_factor, adaptive_.max_factor);
        if (accept) estimate_ = e;
      }
    }
    if (accept) {
      int slot = head_;  // the oldest point, once the history is full
      if (count_ < points_)
        slot = count_++;
      else
        head_ = (head_ + 1) % points_;
      history_.col(slot) = s.q;
      times_[slot] = s.t;
      last_h_ = h;
      ++accepted_;
      // A landing step (shortened) keeps the controller's size unless its estimate asks for less.
      if (!landing)
        h_ = h * factor;
      else if (factor < 1.0)
        h_ = std::min(h_, h * factor);
      return Status::Ok;
    }
    ++rejected_;
    s = saved_;
    h_ = h * factor;
    // A history of steps much longer than the one now tried says little about it (and holds
    // the configurations of steps that may have been too long): start it again at this size.
    if (estimated && h_ < 0.125 * last_h_) count_ = head_ = 0;
    if (h_ < adaptive_.h_min)
      return ws.fail(Status::StepSizeTooSmall,
                     "adaptive step at t = %.17g: the error test failed down to H = %.3g, below h_min = %.3g (the "
                     "last attempt: %s)",
                     s.t, h_, adaptive_.h_min, status == Status::Ok ? "estimate too large" : to_string(status));
  }
}

}  // namespace nonholo
