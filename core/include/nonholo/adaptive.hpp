#pragma once
/// @file
/// Adaptive steps (order 2, and the composed orders 4, 6 and 8 of composition.hpp): the step size H follows an
/// estimate of each step's local error, kept below a budget of 10 tol H / horizon, so that over a
/// run of length `horizon` the error in q ends near tol (README "Adaptive steps": measured from
/// 0.01 to 1 times tol on chains and the sleigh; the errors of these symmetric compositions add
/// up to less than the sum of the local errors, hence the factor 10).
///
/// The estimate is step doubling: each call takes two steps of H and, in the same workspace, one
/// of 2H from the same state; their difference over 2^(p+1) - 2 (p the order) is the local error
/// of a step of H, in the norm |dq| + (horizon / 2) |dv| (a velocity error shifts q for the rest
/// of the run, on average half of it). A pair costs three composed steps. A free estimate (the
/// Milne device: q against the polynomial through the last p + 1 steps) was tried and dropped:
/// its ratio to the local error moved over four decades within one run of a 10-body chain, and
/// calibrating it by sampled doubling still let steps pass events 100 to 500 times off.
/// A pair whose estimate exceeds the budget is rejected and repeated from the same state; the
/// next H is H min(max_factor, max(min_factor, safety (budget / e)^(1/p))). Below the round-off
/// that the difference can resolve the pair is accepted and grows by max_factor; a retried pair
/// whose difference does not fall as h^(p+1) is round-off too (accepted, and the floor raised). The energy
/// projection and the restart of the composed step (RattleOptions::restart) happen at every step.
#include <nonholo/archive.hpp>
#include <nonholo/model.hpp>
#include <nonholo/rattle_options.hpp>
#include <nonholo/state.hpp>
#include <nonholo/status.hpp>
#include <nonholo/workspace.hpp>

#include <limits>

namespace nonholo {

/// The error controller of AdaptiveStepper (see adaptive.hpp).
struct AdaptiveOptions {
  double tol = 1e-8;          ///< the error in q aimed at after `horizon` (see above)
  double horizon = 1.0;       ///< the run's length (set it: a longer run needs smaller local errors)
  double h_initial = 0.01;    ///< the first pair's step size (checked; grows up to 4 max_factor a pair
                              ///< until the controller first asks for less)
  double h_min = 1e-10;       ///< below this the step fails with Status::StepSizeTooSmall
  double h_max = std::numeric_limits<double>::infinity();  ///< the largest step size a pair takes
  double safety = 0.8;  ///< the controller's safety factor, in (0, 1] (see adaptive.hpp)
  /// The step shrinks at most 5 times, grows at most 1.5 times a pair: the next H is H times a
  /// factor in [min_factor, max_factor].
  ///@{
  double min_factor = 0.2;
  double max_factor = 1.5;
  ///@}
};
/// Throws std::invalid_argument naming the field (tol not in (0, 1), horizon or h's not positive
/// and finite, h_min > h_initial or h_max, factors not 0 < min < 1 < max, safety not in (0, 1]).
void validate(const AdaptiveOptions& options);

/// Composed steps of a size that follows the local error estimate (see adaptive.hpp).
class AdaptiveStepper {
 public:
  /// The steps of `options` (order 2: the plain step, restarted at every step since a change of
  /// h would misplace the lambda~ it carries; 4, 6 or 8: composed; options.h is ignored). Sizes
  /// its buffers once for `model`; throws std::invalid_argument for another order or bad options.
  AdaptiveStepper(const Model& model, const RattleOptions& options, const AdaptiveOptions& adaptive);

  /// Advances s by one accepted pair of composed steps of the same size, the second ending at
  /// t_stop exactly if a pair of the controller's size would pass it (the next call then resumes
  /// the size the estimate asked for). Rejected attempts and the shadow step leave s as it was,
  /// bit for bit (the shadow runs in `ws`; a step's result does not depend on what the workspace
  /// did before). A failed composed step (any status) is retried 4 times smaller, a failed
  /// shadow twice smaller; below h_min the call fails with Status::StepSizeTooSmall, s as
  /// before; a t_stop not after s.t gives Status::InvalidStepSize. Never throws, never allocates.
  /// The workspace must allow composed steps (orders 4-8).
  Status step(const Model& model, Workspace& ws, State& s, double t_stop);

  /// Start again from h_initial (after changing the state by hand, say).
  void reset();

  /// Checkpoints (archive.hpp): the controller's state and counters (the options are the
  /// constructor's: a checkpoint of other options is refused).
  ///@{
  void save(OutArchive& a) const;
  void load(InArchive& a);
  ///@}

  double h() const { return h_; }  ///< the size the next pair will try
  double last_step() const { return last_h_; }  ///< the step size of the last accepted pair
  long accepted() const { return accepted_; }   ///< accepted composed steps (two a pair)
  long rejected() const { return rejected_; }   ///< rejected pairs
  double last_estimate() const { return estimate_; }  ///< local error of the last judged pair (NaN before)

 private:
  double doubling_error(const Model& model, const State& pair, const State& shadow, double& noise);

  RattleOptions options_;
  AdaptiveOptions adaptive_;
  int order_;
  Vector velocity_, difference_;
  State saved_, shadow_;
  double h_;
  double last_h_ = 0.0;
  long accepted_ = 0, rejected_ = 0;
  bool starting_ = true;  // growing from h_initial (up to 4 max_factor a pair)
  double round_off_ = 1.0;  // the round-off floor of the difference, in units of the first guess
  double estimate_ = std::numeric_limits<double>::quiet_NaN();
};

}  // namespace nonholo
