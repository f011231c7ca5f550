// Sampled step doubling (nonholo/accuracy.hpp): one shadow step of 2h from x_k against the
// run's two steps of h, at intervals of 2 to `every` steps.
#include <nonholo/accuracy.hpp>

#include <nonholo/rattle.hpp>
#include <nonholo/sparse/big_buffer.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <new>
#include <stdexcept>

namespace nonholo {

Extent::Extent(Eigen::Index nq)
    : min_(Vector::Constant(nq, std::numeric_limits<double>::infinity())),
      max_(Vector::Constant(nq, -std::numeric_limits<double>::infinity())) {}

void Extent::include(ConstVecRef q) {
  min_ = min_.cwiseMin(q);
  max_ = max_.cwiseMax(q);
}

double Extent::extent(ConstVecRef q) const { return (max_.cwiseMax(q) - min_.cwiseMin(q)).maxCoeff(); }

double Extent::largest_coordinate(ConstVecRef q) const {
  return std::max(max_.cwiseMax(q).cwiseAbs().maxCoeff(), min_.cwiseMin(q).cwiseAbs().maxCoeff());
}

void Extent::load(InArchive& a) {
  if (size() > 0) {  // sized by the model: a checkpoint of another size is refused
    a(min_), a(max_);
    return;
  }
  a.resize_into(min_);
  a.resize_into(max_);
}

double doubling_factor(int order) { return std::ldexp(1.0, order + 1) - 2.0; }

double companion_estimate(double difference, double ratio, double allowed) {
  const double richardson = difference / std::abs(ratio - 1.0);
  return std::max(ratio, 1.0) * richardson > allowed ? 3.0 * richardson : richardson;
}

DoublingEstimate::DoublingEstimate(Eigen::Index nq, int order, int every)
    : every_(every), factor_(doubling_factor(order)), single_factor_(1.0 - std::ldexp(1.0, -order)) {
  if (every < 2 || every % 2 != 0)
    throw std::invalid_argument("accuracy check: every = " + std::to_string(every) + " must be even and at least 2");
  range_ = Extent(nq);
  first_failure_.reserve(512);  // the first failure's text is copied in a step: no allocation there
}

void DoublingEstimate::include(ConstVecRef q) {
  range_.include(q);
}

void DoublingEstimate::failed(double t, const char* status, const char* message) {
  next_at_ = step_ + every_;  // try again later (a retry's sample sets its own next)
  // The run's step size is within a factor 2 of failing: say so once, keep the count.
  if (failed_++ == 0) {
    char text[512];
    std::snprintf(text, sizeof text, "t = %.6g: %s: %s", t, status, message);
    first_failure_.assign(text);
  }
}

double DoublingEstimate::estimate() const {
  if (last_end_ < 0) return error_.at(t_);
  const double tail = static_cast<double>(step_ - last_end_);  // steps since the last sample
  GlobalError e = error_;
  e.add(0.5 * (last_t_ + t_), tail, last_dq_, last_dv_);
  return e.at(t_);
}

double DoublingEstimate::extent() const {
  if (!last_q_) return 0.0;
  return range_.extent(Eigen::Map<const Vector>(last_q_, range_.size()));
}

double DoublingEstimate::largest_coordinate() const {
  if (!last_q_) return 0.0;
  return range_.largest_coordinate(Eigen::Map<const Vector>(last_q_, range_.size()));
}

namespace {

// Do two samples' local errors agree within a factor 4? Values below the floor (round-off)
// count as the floor.
bool agree(double a, double b, double floor) {
  a = std::max(a, floor);
  b = std::max(b, floor);
  return a <= 4.0 * b && b <= 4.0 * a;
}

}  // namespace

void DoublingEstimate::sample(double t, double h, double dq, double dv, double speed, double q_norm) {
  ++samples_;
  const bool single = single_;  // one step of h against two of h/2 (a step of 2h had failed)
  single_ = false;
  singles_ += single;
  const long steps = single ? 1 : 2;
  const double factor = single ? single_factor_ : factor_;
  const bool fast = dv > 1e-2 * speed;
  fast_ += fast;
  dq /= factor;
  dv /= factor;
  if (dq > local_max_ || dq != dq) local_max_ = dq;
  const double t_pair = t - 0.5 * static_cast<double>(steps) * h;  // the sample's middle
  // Step doubling splits the difference as (2^(p+1) - 2) local errors only in the asymptotic
  // regime. A pair whose velocities differ by more than 1 % of the speed, followed by one a
  // hundred times quieter, was a transient faster than the step (blades through the centres of
  // mass with inertia 1e-10 turn in far less than a step): it counts whole, as the local error it
  // may be. (A motion that stays that fast, omega0 = 20 on the chain, keeps the split.)
  if (last_fast_ && dv < 1e-2 * last_dv_) {
    error_.add(last_t_, 2.0, (factor_ - 1.0) * last_dq_, (factor_ - 1.0) * last_dv_);
    if (transients_++ == 0) first_transient_t_ = last_t_ - h;
  }
  last_fast_ = fast && !single;  // (a single step's difference is most of its whole error already)
  // The sample's own steps, and the stretch since the previous sample at the two samples' mean.
  error_.add(t_pair, static_cast<double>(steps), dq, dv);
  if (last_end_ >= 0) {
    const double gap = static_cast<double>(step_ - steps - last_end_);
    if (gap > 0) error_.add(0.5 * (last_t_ + t_pair), gap, 0.5 * (dq + last_dq_), 0.5 * (dv + last_dv_));
    // Round-off of the difference of two states: a few ulps of the largest coordinate, over the factor.
    const double q_floor = 8.0 * std::numeric_limits<double>::epsilon() * q_norm / factor;
    const double v_floor = 8.0 * std::numeric_limits<double>::epsilon() * speed / factor;
    const bool steady = agree(dq, last_dq_, q_floor) && agree(dv, last_dv_, v_floor);
    interval_ = steady ? std::min<long>(2 * interval_, every_) : std::max<long>(2, interval_ / 4);
  }
  last_end_ = step_;
  last_dq_ = dq;
  last_dv_ = dv;
  last_t_ = t_pair;
  next_at_ = step_ - steps + interval_;
}

namespace {

RattleOptions scaled(RattleOptions o, double by) {
  o.h *= by;
  return o;
}

// The differences of a finished pair (shadow minus run) fed to the estimate: q, and the velocity
// M^-1 p; `velocity` and `difference` are scratch of n_v entries (the workspace's).
void feed(const Model& model, DoublingEstimate& e, double t, double h, ConstVecRef q_shadow, ConstVecRef q,
          ConstVecRef p_shadow, ConstVecRef p, Vector& velocity, Vector& difference) {
  const double dq = (q_shadow - q).lpNorm<Eigen::Infinity>();
  difference = p_shadow - p;
  model.inverse_mass().multiply(difference.data(), velocity.data());
  const double dv = velocity.lpNorm<Eigen::Infinity>();
  model.inverse_mass().multiply(p.data(), velocity.data());
  e.sample(t, h, dq, dv, velocity.lpNorm<Eigen::Infinity>(), q.lpNorm<Eigen::Infinity>());
}

}  // namespace

AccuracyWatch::AccuracyWatch(Workspace& run, const RattleOptions& options, int every)
    : model_(run.model()),
      ws_(run),
      options_(scaled(options, 2.0)),
      halved_(scaled(options, 0.5)),
      estimate_(run.model().num_configuration(), options.order, every) {}

AccuracyWatch::AccuracyWatch(const Model& model, const WorkspaceOptions& workspace, const RattleOptions& options,
                             int every)
    : model_(model),
      own_(std::make_unique<Workspace>(model, workspace)),
      ws_(*own_),
      options_(scaled(options, 2.0)),
      halved_(scaled(options, 0.5)),
      estimate_(model.num_configuration(), options.order, every) {}

// The shadow's held caches and state (huge pages asked for), made once: at the first sample, or
// when a checkpoint with a sample under way is loaded.
void AccuracyWatch::make_shadow() {
  held_ = ws_.make_held();
  sparse::zero_buffer(shadow_.q, model_.num_configuration());
  sparse::zero_buffer(shadow_.p, model_.num_velocities());
  sparse::zero_buffer(shadow_.lambda, model_.num_one_forms());
  sparse::zero_buffer(shadow_.force, model_.num_velocities());
  held_made_ = true;  // last: an allocation that failed leaves it to be tried again
}

// One step of the shadow with its own held caches swapped in and the run's (at the run's q) put
// back after; from the run's state s when `from_run`, else from the shadow's own. The held set
// comes in valid at the shadow's q (its key is made from that q), so the shadow takes the run's
// state only once it is in. A failure's message is read before the run steps again.
Status AccuracyWatch::shadow_step(const State& s, const RattleOptions& o, bool from_run) {
  ws_.swap_held(held_, s.q.data(), shadow_.q.data());  // allocates only in a rare case (Workspace::swap_held)
  if (from_run) shadow_ = s;                           // same sizes: a copy, no allocation
  const Status status = step(model_, ws_, shadow_, o);
  ws_.swap_held(held_, s.q.data(), shadow_.q.data());
  return status;
}

// The shadow's step of 2h from the run's state; if it fails, two steps of h/2 from it instead,
// set against the run's next step alone (veselova at dt 0.6, whose step of 2h always fails, ended
// ok unjudged 44-72 % of its extent off).
void AccuracyWatch::start_shadow(State& s) {
  estimate_.include(s.q);
  try {
    if (!held_made_) make_shadow();
    Status status = shadow_step(s, options_, true);
    if (status == Status::Ok) {
      estimate_.started();
      return;
    }
    estimate_.failed(s.t, to_string(status), ws_.message());
    status = shadow_step(s, halved_, true);
    if (status == Status::Ok) status = shadow_step(s, halved_, false);
    if (status == Status::Ok) estimate_.started_single();
  } catch (const std::bad_alloc&) {
    estimate_.failed(s.t, "out-of-memory", "no memory for the accuracy check's shadow step");
  }
}

void AccuracyWatch::finish_shadow(const State& s) {
  feed(model_, estimate_, s.t, options_.h / 2, shadow_.q, s.q, shadow_.p, s.p, ws_.scratch_n, ws_.scratch_n2);
}

void DoublingEstimate::save(OutArchive& a) const {
  a.tag("doubling-estimate");
  a(every_), a(factor_);
  range_.save(a);
  error_.save(a);
  a(step_), a(pending_at_), a(next_at_), a(interval_), a(last_end_), a(last_dq_), a(last_dv_), a(last_t_);
  a(last_fast_), a(t_), a(local_max_), a(samples_), a(failed_), a(transients_), a(fast_), a(first_transient_t_);
  a(first_failure_), a(single_), a(singles_);
}

void DoublingEstimate::load(InArchive& a) {
  a.tag("doubling-estimate");
  int every = 0;
  double factor = 0.0;
  a(every), a(factor);
  if (every != every_ || factor != factor_)
    throw std::runtime_error("checkpoint: the accuracy check's sampling (every " + std::to_string(every) +
                             ") or order differs from this run's (every " + std::to_string(every_) + ")");
  range_.load(a);
  error_.load(a);
  a(step_), a(pending_at_), a(next_at_), a(interval_), a(last_end_), a(last_dq_), a(last_dv_), a(last_t_);
  a(last_fast_), a(t_), a(local_max_), a(samples_), a(failed_), a(transients_), a(fast_), a(first_transient_t_);
  a(first_failure_), a(single_), a(singles_);
  last_q_ = nullptr;
}

// The shadow only while a sample is under way (a state's worth of bytes otherwise saved).
void AccuracyWatch::save(OutArchive& a) const {
  estimate_.save(a);
  if (estimate_.pending()) nonholo::save(a, shadow_);
}

void AccuracyWatch::load(InArchive& a) {
  estimate_.load(a);
  if (!estimate_.pending()) return;
  if (!held_made_) make_shadow();
  nonholo::load(a, shadow_);
}

}  // namespace nonholo
