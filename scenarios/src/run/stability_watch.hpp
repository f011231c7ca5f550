#pragma once
// The run's guard against the explicit methods' stability limit (core: nonholo/stability.hpp).
// At the start it estimates the stiffest frequency omega of the applied forces on the
// constrained motion and refuses a step at or beyond the method's limit; every kEvery steps
// it refreshes the estimate from the last one (a few warm-started iterations: the constraint
// distribution and nonlinear forces change omega along the motion). ratio() is the largest
// h / limit seen: the summary's stability_ratio, with a warning from kWarnRatio on.
#include <nonholo/model.hpp>
#include <nonholo/stability.hpp>
#include <nonholo/status.hpp>

#include <limits>
#include <memory>
#include <string>

#include "run/runners.hpp"

namespace nonholo::scenarios {

class StabilityWatch {
 public:
  static constexpr long kEvery = 1024;
  static constexpr double kWarnRatio = 0.5;  // h omega >= 1 at order 2: phase error ~ 4% per period

  // Active for the explicit fixed-step methods (reflection, rk4) on models with applied forces.
  StabilityWatch(const Model& model, const MethodChoice& choice, double dt);
  bool active() const { return limit_factor_ > 0.0; }
  // Called before step `step` (0: the start). Ok, or UnstableStepSize with why in message.
  Status check(Runner& runner, long step, std::string& message);
  double ratio() const { return ratio_; }  // NaN while inactive
  std::string warning() const;
  void save(OutArchive& a) const;
  void load(InArchive& a);

 private:
  const Model& model_;
  double dt_;
  double limit_factor_ = 0.0;  // limit = limit_factor_ / omega
  std::string method_;
  sparse::Backend backend_;
  StiffnessEstimate estimate_;
  std::unique_ptr<Workspace> own_;  // when the runner has no workspace to lend
  double ratio_ = std::numeric_limits<double>::quiet_NaN();
  double omega_max_ = 0.0;
};

}  // namespace nonholo::scenarios
