// Sampled step doubling (nonholo/accuracy.hpp): one shadow step of 2h from x_k against the
// run's two steps of h, every `every` steps.
#include <nonholo/accuracy.hpp>

#include <nonholo/rattle.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <cstdio>
#include <stdexcept>

namespace nonholo {

double doubling_factor(int order) { return std::ldexp(1.0, order + 1) - 2.0; }

namespace {

RattleOptions doubled(RattleOptions o) {
  o.h *= 2.0;
  return o;
}

}  // namespace

AccuracyWatch::AccuracyWatch(const Model& model, const WorkspaceOptions& workspace, const RattleOptions& options,
                             int every)
    : model_(model),
      ws_(model, workspace),
      options_(doubled(options)),
      every_(every),
      factor_(doubling_factor(options.order)) {
  if (every < 2 || every % 2 != 0)
    throw std::invalid_argument("AccuracyWatch: every = " + std::to_string(every) + " must be even and at least 2");
  const Eigen::Index nq = model.num_configuration(), nv = model.num_velocities(), m = model.num_one_forms();
  shadow_.q.setZero(nq);
  shadow_.p.setZero(nv);
  shadow_.lambda.setZero(m);
  shadow_.force.setZero(nv);
  velocity_.setZero(nv);
  q_min_.setConstant(nq, std::numeric_limits<double>::infinity());
  q_max_.setConstant(nq, -std::numeric_limits<double>::infinity());
  difference_.setZero(nv);
  first_failure_.reserve(512);  // the first failure's text is copied in a step: no allocation there
}

void AccuracyWatch::before_step(const State& s) {
  if (pending_at_ >= 0 || step_ < next_at_) return;
  q_min_ = q_min_.cwiseMin(s.q);
  q_max_ = q_max_.cwiseMax(s.q);
  shadow_ = s;  // same sizes: a copy, no allocation
  const Status status = step(model_, ws_, shadow_, options_);
  if (status == Status::Ok) {
    pending_at_ = step_ + 2;
    return;
  }
  next_at_ = step_ + every_;  // failed: try again later
  // The run's step size is within a factor 2 of failing: say so once, keep the count.
  if (failed_++ == 0) {
    char text[512];
    std::snprintf(text, sizeof text, "t = %.6g: %s: %s", s.t, to_string(status), ws_.message());
    first_failure_.assign(text);
  }
}

double AccuracyWatch::estimate() const {
  if (last_end_ < 0) return error_.at(t_);
  const double tail = static_cast<double>(step_ - last_end_);  // steps since the last sample
  GlobalError e = error_;
  e.add(0.5 * (last_t_ + t_), tail, last_dq_, last_dv_);
  return e.at(t_);
}

double AccuracyWatch::extent() const {
  if (!last_) return 0.0;
  return (q_max_.cwiseMax(last_->q) - q_min_.cwiseMin(last_->q)).maxCoeff();
}

double AccuracyWatch::largest_coordinate() const {
  if (!last_) return 0.0;
  return std::max(q_max_.cwiseMax(last_->q).cwiseAbs().maxCoeff(), q_min_.cwiseMin(last_->q).cwiseAbs().maxCoeff());
}

namespace {

// Do two samples' local errors agree within a factor 2? Values below the floor (round-off)
// count as the floor.
bool agree(double a, double b, double floor) {
  a = std::max(a, floor);
  b = std::max(b, floor);
  return a <= 4.0 * b && b <= 4.0 * a;
}

}  // namespace

void AccuracyWatch::after_step(const State& s) {
  ++step_;
  t_ = s.t;
  last_ = &s;
  if (pending_at_ != step_) return;
  pending_at_ = -1;
  ++samples_;
  double dq = (shadow_.q - s.q).lpNorm<Eigen::Infinity>();
  difference_ = shadow_.p - s.p;
  model_.inverse_mass().multiply(difference_.data(), velocity_.data());
  double dv = velocity_.lpNorm<Eigen::Infinity>();
  model_.inverse_mass().multiply(s.p.data(), velocity_.data());
  const double speed = velocity_.lpNorm<Eigen::Infinity>();
  const bool fast = dv > 1e-2 * speed;
  fast_ += fast;
  dq /= factor_;
  dv /= factor_;
  // Step doubling splits the difference as (2^(p+1) - 2) local errors only in the asymptotic
  // regime. A pair whose velocities differ by more than 1 % of the speed, followed by one a
  // hundred times quieter, was a transient faster than the step (blades through the centres of
  // mass with inertia 1e-10 turn in far less than a step): it counts whole, as the local error it
  // may be. (A motion that stays that fast, omega0 = 20 on the chain, keeps the split.)
  if (last_fast_ && dv < 1e-2 * last_dv_) {
    error_.add(last_t_, 2.0, (factor_ - 1.0) * last_dq_, (factor_ - 1.0) * last_dv_);
    if (transients_++ == 0) first_transient_t_ = last_t_ - options_.h / 2;
  }
  last_fast_ = fast;
  if (dq > local_max_ || dq != dq) local_max_ = dq;
  // The pair's own two steps, and the stretch since the previous pair at the two samples' mean.
  const double t_pair = s.t - options_.h / 2;
  error_.add(t_pair, 2.0, dq, dv);
  if (last_end_ >= 0) {
    const double gap = static_cast<double>(step_ - 2 - last_end_);
    if (gap > 0) error_.add(0.5 * (last_t_ + t_pair), gap, 0.5 * (dq + last_dq_), 0.5 * (dv + last_dv_));
    // Round-off of the difference of two states: a few ulps of the largest coordinate, over the factor.
    const double q_floor = 8.0 * std::numeric_limits<double>::epsilon() * s.q.lpNorm<Eigen::Infinity>() / factor_;
    const double v_floor = 8.0 * std::numeric_limits<double>::epsilon() * speed / factor_;
    const bool steady = agree(dq, last_dq_, q_floor) && agree(dv, last_dv_, v_floor);
    interval_ = steady ? std::min<long>(2 * interval_, every_) : std::max<long>(2, interval_ / 4);
  }
  last_end_ = step_;
  last_dq_ = dq;
  last_dv_ = dv;
  last_t_ = t_pair;
  next_at_ = step_ - 2 + interval_;
}

}  // namespace nonholo
