#pragma once
// Adaptive composed steps (orders 4, 6 and 8, composition.hpp): the step size H follows an
// error estimate that costs no extra factorisation. After each composed step the configuration q
// at its end is compared with the polynomial through the configurations of the last p + 1
// accepted steps (p the order), extrapolated to the new time: a Milne-device estimate, of order
// p + 1 in H like the step's own local error, and a multiple of it on smooth motion. A step
// whose estimate e exceeds kappa tol H (error per unit step, so that the error at the end falls
// in proportion to tol; kappa calibrated per order, README "Adaptive steps") is rejected and
// repeated from the same state with a smaller H; the next H is
// H min(max_factor, max(min_factor, safety (kappa tol H / e)^(1/p))). Below the round-off that
// the extrapolation amplifies the estimate says nothing: the step is accepted and grows by 1.25.
// The first p + 1 steps have no history: they take h_initial, unchecked (choose it small; the
// steps then grow by at most max_factor each); a rejection to below 1/8 of the last accepted
// step starts the history again. The energy projection and the restart of the composed step
// (RattleOptions::restart) happen at every accepted step, as with fixed steps.
// Measured limits (README "Adaptive steps"): the error at the end is within 10 times tol on the
// sleigh (orders 4, 6: tol 1e-4 ... 1e-11) and on chains of 10 bodies for tol <= 1e-5 (order
// 4) and <= 1e-8 (order 6); at looser tolerances on chains the steps outgrow the estimate (up
// to 1000 times tol on 100 bodies); order 8 is not proportional (its errors fall faster than tol).
#include <nonholo/model.hpp>
#include <nonholo/rattle_options.hpp>
#include <nonholo/state.hpp>
#include <nonholo/status.hpp>
#include <nonholo/workspace.hpp>

#include <limits>

namespace nonholo {

struct AdaptiveOptions {
  double tol = 1e-8;          // the error in q aimed at (see above)
  double h_initial = 0.01;    // the steps before the estimate has its history
  double h_min = 1e-10;       // below this the step fails with Status::StepSizeTooSmall
  double h_max = std::numeric_limits<double>::infinity();
  double safety = 0.9;
  double min_factor = 0.2;    // the step shrinks at most 5 times, grows at most 2 times a step
  double max_factor = 2.0;
};
// Throws std::invalid_argument naming the field (tol not in (0, 1), h's not positive or
// h_min > h_initial or h_max, factors not 0 < min < 1 < max, safety not in (0, 1]).
void validate(const AdaptiveOptions& options);

class AdaptiveStepper {
 public:
  // The composed steps of `options` (order 4, 6 or 8; options.h is ignored). Sizes its buffers
  // once for `model`; throws std::invalid_argument for order 2 or bad options.
  AdaptiveStepper(const Model& model, const RattleOptions& options, const AdaptiveOptions& adaptive);

  // One accepted composed step from s, ending at t_stop exactly if the step would pass it (the
  // next step then resumes the size the estimate asked for). Rejected attempts leave s as it
  // was, bit for bit. A failed composed step (any status) is retried with a step 4 times
  // smaller, like a rejection; below h_min the step fails with Status::StepSizeTooSmall, s as
  // before; a t_stop not after s.t gives Status::InvalidStepSize. Never throws, never
  // allocates. The workspace must allow composed steps.
  Status step(const Model& model, Workspace& ws, State& s, double t_stop);

  // After changing the state by hand: forget the history (the next steps take h_initial).
  void reset();

  double h() const { return h_; }  // the size the next step will try
  double last_step() const { return last_h_; }  // the size of the last accepted step
  long accepted() const { return accepted_; }
  long rejected() const { return rejected_; }
  double last_estimate() const { return estimate_; }  // e of the last accepted step (NaN before)

 private:
  double extrapolation_error(double t, ConstVecRef q, double& noise);  // |q - P(t)|_inf
  RattleOptions options_;
  AdaptiveOptions adaptive_;
  int order_;
  int points_;       // p + 1 history points
  Eigen::MatrixXd history_;  // n_q x points_: the configurations (a ring; the oldest at head_)
  Vector times_;     // their times
  int count_ = 0, head_ = 0;
  Vector predicted_;
  State saved_;
  double h_;
  double last_h_ = 0.0;  // the last accepted step
  long accepted_ = 0, rejected_ = 0;
  double estimate_ = std::numeric_limits<double>::quiet_NaN();
};

}  // namespace nonholo
