// The run's stability watch (stability_watch.hpp): the method's limit factor, the stiffest frequency
// estimated every kEvery steps, a step refused at or beyond the limit, and the warning from half of it.
#include "run/stability_watch.hpp"

#include <cmath>
#include <sstream>

namespace nonholo::scenarios {

StabilityWatch::StabilityWatch(const Model& model, const MethodChoice& choice, double dt)
    : model_(model), dt_(dt), method_(choice.method), backend_(choice.backend) {
  // Adaptive steps are not dt long, and a step beyond the limit fails their error test.
  if (!model.has_applied_force() || choice.adaptive_on()) return;
  if (choice.method == "reflection")  // limit = factor / omega
    limit_factor_ = stability_limit(1.0, choice.rattle.order, choice.rattle.composition);
  else if (choice.method == "rk4")
    limit_factor_ = 2.0 * std::sqrt(2.0);  // RK4 on the imaginary axis
}

void StabilityWatch::save(OutArchive& a) const {
  a.tag("stability");
  a(estimate_.omega), a(estimate_.iterations), a(estimate_.converged), a(estimate_.direction);
  a(ratio_), a(omega_max_);
}

void StabilityWatch::load(InArchive& a) {
  a.tag("stability");
  a(estimate_.omega), a(estimate_.iterations), a(estimate_.converged);
  a.resize_into(estimate_.direction);
  a(ratio_), a(omega_max_);
}

Status StabilityWatch::check(Runner& runner, long step, std::string& message) {
  if (!active() || (step > 0 && step % kEvery != 0)) return Status::Ok;
  Workspace* ws = runner.workspace();
  if (!ws) {
    if (!own_) own_ = std::make_unique<Workspace>(model_, WorkspaceOptions{backend_, false});
    ws = own_.get();
  }
  try {
    estimate_ = step == 0 ? stiffest_frequency(model_, *ws, runner.t(), runner.q())
                          : stiffest_frequency(model_, *ws, runner.t(), runner.q(), &estimate_, 4);
  } catch (const std::exception&) {
    return Status::Ok;  // dependent one-forms here: the step itself reports them
  }
  omega_max_ = std::max(omega_max_, estimate_.omega);
  const double ratio = dt_ * estimate_.omega / limit_factor_;
  if (!(ratio <= ratio_)) ratio_ = ratio;
  if (!(ratio >= 1.0)) return Status::Ok;
  std::ostringstream os;
  os.precision(3);
  os << "dt = " << dt_ << " is " << ratio << " times the stability limit " << limit_factor_ / estimate_.omega
     << " of the " << method_ << " step at t = " << runner.t() << ": the stiffest oscillation of the forces on the "
     << "constrained motion has omega = " << estimate_.omega
     << " rad per unit time, and the explicit step grows it by a factor every step beyond the limit; use --dt "
     << 0.5 * limit_factor_ / estimate_.omega << " or smaller (half the limit), or an implicit method";
  message = os.str();
  return Status::UnstableStepSize;
}

std::string StabilityWatch::warning() const {
  if (!(ratio_ >= kWarnRatio) || !(ratio_ < 1.0)) return "";
  std::ostringstream os;
  os.precision(3);
  os << "dt = " << dt_ << " is " << ratio_ << " of the " << method_ << " step's stability limit (stiffest omega = "
     << omega_max_ << ", stability_ratio): stable, but the fastest oscillation is resolved with about "
     << 2.0 * M_PI / (dt_ * omega_max_) << " steps per period and its frequency and phase are off by percents; "
     << "use --dt " << 0.5 * kWarnRatio * limit_factor_ / omega_max_ << " for accuracy";
  return os.str();
}

}  // namespace nonholo::scenarios
