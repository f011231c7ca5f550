// The run's bounds (run_checks.hpp): the work integral of external forces, the relative residual, the
// hitches' lever arm, the blew-up messages for energy and constraints, and the coordinates' precision watch.
#include "run/run_checks.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

namespace nonholo::scenarios {

void WorkIntegral::save(OutArchive& a) const {
  a(h_), a(n_), a(sum_);
  for (double x : first_) a(x);
  for (double x : last_) a(x);
}

void WorkIntegral::load(InArchive& a) {
  a(h_), a(n_), a(sum_);
  for (double& x : first_) a(x);
  for (double& x : last_) a(x);
}

void WorkIntegral::start(double power, double h) {
  h_ = h;
  n_ = 0;
  sum_ = 0.0;
  first_[0] = last_[0] = power;
}

void WorkIntegral::add(double power) {
  sum_ += 0.5 * (last_[0] + power);
  ++n_;
  if (n_ <= kDifferences) first_[n_] = power;
  for (int i = kDifferences; i > 0; --i) last_[i] = last_[i - 1];
  last_[0] = power;
}

double WorkIntegral::value() const {
  // Gregory: h sum'' P - sum_k c_k h (nabla^k P_n + (-1)^k Delta^k P_0), k = 1 ... r, with r
  // limited by the points there are (fewer steps: a lower order, exact for fewer degrees).
  static constexpr double c[kDifferences] = {1.0 / 12.0, 1.0 / 24.0, 19.0 / 720.0, 3.0 / 160.0};
  const int r = static_cast<int>(std::min<long>(kDifferences, n_));
  double forward[kDifferences + 1], backward[kDifferences + 1];
  std::copy(first_, first_ + r + 1, forward);
  std::copy(last_, last_ + r + 1, backward);
  double w = sum_;
  for (int k = 1; k <= r; ++k) {
    for (int i = 0; i + k <= r; ++i) {  // the k-th differences, in place
      forward[i] = forward[i + 1] - forward[i];
      backward[i] = backward[i] - backward[i + 1];
    }
    w -= c[k - 1] * (backward[0] + (k % 2 == 0 ? forward[0] : -forward[0]));
  }
  return h_ * w;
}

double relative_residual(const sparse::RowPattern& pattern, const double* mu, ConstVecRef v) {
  const double v_max = v.lpNorm<Eigen::Infinity>();
  if (!(v_max > 0.0)) return v_max == 0.0 ? 0.0 : std::numeric_limits<double>::quiet_NaN();
  const int* rp = pattern.row_ptr.data();
  const int* ci = pattern.col_idx.data();
  double worst = 0.0;
  for (int r = 0; r < pattern.rows; ++r) {
    double s = 0.0, norm = 0.0;
    for (int k = rp[r]; k < rp[r + 1]; ++k) {
      s += mu[k] * v[ci[k]];
      norm += std::abs(mu[k]);
    }
    if (norm == 0.0) continue;  // a row of zeros: v satisfies it
    const double rel = std::abs(s) / (norm * v_max);
    if (!(rel <= worst)) worst = rel;  // NaN stays
  }
  return worst;
}

double hitch_lever_arm(const Model& model, ConstVecRef q, Workspace* ws) {
  if (model.num_holonomic() == 0) return 0.0;
  // The rotation columns, as a mask over the velocity entries.
  std::vector<char> rotation(static_cast<std::size_t>(model.num_velocities()), 0);
  for (int b = 0; b < model.num_bodies(); ++b) {
    const Body& body = model.body(b);
    if (body.kind == BodyKind::Planar) rotation[body.offset + 2] = 1;
    if (body.kind == BodyKind::Rigid) std::fill_n(rotation.begin() + body.offset, 3, 1);
  }
  const sparse::RowPattern& pattern = model.one_form_pattern();
  Vector own;
  if (ws && ws->evaluate_one_forms(q) != Status::Ok) return 0.0;  // mu not finite: the step says so
  if (!ws) {
    own.resize(pattern.nnz());
    model.one_form_values(q, own);
  }
  const double* mu = ws ? ws->mu_values.data() : own.data();
  double arm = 0.0;
  for (const int r : model.holonomic_rows())
    for (int k = pattern.row_ptr[r]; k < pattern.row_ptr[r + 1]; ++k)
      if (rotation[pattern.col_idx[k]] && std::isfinite(mu[k])) arm = std::max(arm, std::abs(mu[k]));
  return arm;
}

double external_power(const Model& model, double t, ConstVecRef q, ConstVecRef v, VecRef force) {
  if (!model.has_external_force() || v.size() == 0) return model.has_external_force() ? NAN : 0.0;
  model.external_force(t, q, force);
  return force.dot(v);
}

namespace {

std::string after_step(long step, double t) {
  std::ostringstream os;
  os << "after step " << step << " (t = " << t << ")";
  return os.str();
}

}  // namespace

Status energy_blew_up(double error, bool balance, long step, double t, const std::string& advice,
                      std::string& message) {
  std::ostringstream os;
  os.precision(3);
  os << after_step(step, t) << " the energy " << (balance ? "balance error (energy_balance_err, net of the work)"
                                                          : "error (energy_rel_err)")
     << " is " << error << ", past the bound " << kEnergyBound
     << " (half the energy lost or gained): the trajectory blew up; " << advice;
  message = os.str();
  return Status::BlewUp;
}

Status constraint_broken(double relative_residual, double gap, double lever_arm, long step, double t,
                         std::string& message) {
  std::ostringstream os;
  os.precision(3);
  if (relative_residual > kResidualBound) {
    os << after_step(step, t) << " the relative constraint residual (residual_rel, |mu v| against |mu| |v|) is "
       << relative_residual << ", past the bound " << kResidualBound
       << ": the velocity no longer satisfies the constraints; reduce --dt";
  } else {
    os << after_step(step, t) << " a hitch gap (gap) is " << gap << ", " << gap / lever_arm
       << " times the hitches' longest lever arm " << lever_arm << " (bound " << kGapBound
       << "): the hitched bodies came apart; reduce --dt (or keep the hitches closed: --hitch holonomic for "
          "reflection, --project for rk4 and arkode)";
  }
  message = os.str();
  return Status::BlewUp;
}

PrecisionWatch::PrecisionWatch(const Model& model, double speed_floor, double span)
    : model_(model), speed_floor_(speed_floor), span_(span) {}

namespace {

// The distance from |x| to the next double up.
double ulp(double x) {
  const double a = std::abs(x);
  return std::nextafter(a, std::numeric_limits<double>::infinity()) - a;
}

}  // namespace

Status PrecisionWatch::check(ConstVecRef q, ConstVecRef v, double h, long step, std::string& message) {
  if (v.size() == 0) return Status::Ok;
  const double fastest = v.lpNorm<Eigen::Infinity>();
  const double moving = kMoving * fastest;
  if (!(moving > 0.0) || fastest <= speed_floor_) return Status::Ok;  // at rest (or not finite: the step reports that)
  // The coordinate whose step keeps the fewest digits, log10(h |v_i| / ulp(q_i)).
  double fewest = std::numeric_limits<double>::infinity();
  int worst_q = -1, worst_v = -1;
  auto consider = [&](int iq, int iv) {
    if (!(std::abs(v[iv]) >= moving) || std::abs(v[iv]) * span_ <= ulp(q[iq])) return;
    const double digits = std::log10(std::abs(h * v[iv]) / ulp(q[iq]));
    if (digits < fewest) {
      fewest = digits;
      worst_q = iq;
      worst_v = iv;
    }
  };
  for (int b = 0; b < model_.num_bodies(); ++b) {
    const Body& body = model_.body(b);
    if (body.kind == BodyKind::Rigid) {  // the centre only: a unit quaternion has ulps of 1e-16
      for (int j = 0; j < body.translation; ++j) consider(body.q_offset + 4 + j, body.offset + 3 + j);
    } else {
      for (int j = 0; j < body.size; ++j) consider(body.q_offset + j, body.offset + j);
    }
  }
  if (worst_q < 0 || fewest >= kWarnDigits) return Status::Ok;
  const double displacement = std::abs(h * v[worst_v]);
  const double u = ulp(q[worst_q]);
  std::ostringstream os;
  os.precision(3);
  const std::string name(model_.coordinate_name(worst_q));
  os << "coordinate " << name << " = " << q[worst_q] << " at step " << step << ": its ulp is " << u
     << " and a step moves it by h |v| = " << displacement;
  // Lost: q + d rounds back to q when d is at most half an ulp.
  if (displacement <= 0.5 * u) {
    os << ", below half an ulp: every step rounds back to the same value and " << name
       << " never moves; move the scene nearer the origin (|" << name << "| below "
       << std::pow(10.0, -kWarnDigits) * h * moving / std::numeric_limits<double>::epsilon()
       << " keeps 6 digits of a step at a hundredth of the fastest speed now) or lengthen --dt (to at least " << u / std::abs(v[worst_v])
       << " for a step of one ulp)";
    message = os.str();
    return Status::PrecisionLoss;
  }
  if (warning_.empty()) {
    os.precision(2);
    os << ": the step keeps " << fewest << " digits (fewer than " << kWarnDigits
       << "), and the rounding of every step adds up; move the scene nearer the origin or lengthen --dt";
    warning_ = os.str();
  }
  return Status::Ok;
}

}  // namespace nonholo::scenarios
