#pragma once
// The bounds `nonholo run` checks along every trajectory, whatever the method and order: the
// energy (net of the work of external forces), the constraints (the relative residual of the
// velocity, the hitch gaps against the hitches' lever arms) and the precision of the
// coordinates. Each threshold says why a correct run cannot reach it.
#include <nonholo/archive.hpp>
#include <nonholo/model.hpp>
#include <nonholo/status.hpp>
#include <nonholo/workspace.hpp>

#include <string>

namespace nonholo::scenarios {

// Past this relative energy error (net of the work) a run stops with blew-up. A correct run of
// order p >= 2 is off by O((h/T)^p) in energy, T the motion's time scale; half the energy gained
// or lost needs h comparable to T, where no method here follows the motion any more.
inline constexpr double kEnergyBound = 0.5;

// Past this relative residual (relative_residual) a run stops with blew-up. The reflection and
// projected methods hold it at round-off (1e-16 ... 1e-12); dla-left's velocity satisfies the
// constraint at q_{k-1}, so at q_k it is off by about h |omega| (the turn of a step), and the
// velocity methods drift by their global error. A quarter of the velocity across its constraint
// takes a turn of 15 degrees a step, far from a correct run.
inline constexpr double kResidualBound = 0.25;

// The relative residual costs a pass over mu (and, after a fused chain step, mu itself): every
// step, a third of the one-body sleigh's step and 13 % of a 1000-body chain's (callgrind). It is
// sampled after the first step, every kResidualEvery-th and the last: a velocity leaving its
// constraint does so over many steps. Odd, so that a period-2 alternation (dla-midpoint's
// residual, the reflection step's parasitic mode) is seen at both phases.
inline constexpr long kResidualEvery = 7;

// Past this gap, as a fraction of the hitches' longest lever arm (hitch_lever_arm), a run stops
// with blew-up. The holonomic mode holds the gap at its Newton tolerance; the velocity-level
// modes let it drift by their global position error, which on a correct run is a small
// fraction of a body's size. A gap of a tenth of the hitch's length means that the hitched
// bodies visibly came apart.
inline constexpr double kGapBound = 0.1;

// The work of the external forces, W(t_n) = integral of the power P from t_0 to t_n, from P at
// the step ends, by Gregory's rule: the trapezoid sum corrected at both ends by differences up
// to the fourth, exact for polynomials of degree 5 from four steps on and of order 6 in h
// (checked against exact integrals by tests/test_run_bounds.cpp). The error stays below that of an order-6 method; the
// order-2 reflection step has its exact discrete identity instead (run_loop.cpp).
class WorkIntegral {
 public:
  void start(double power, double h);
  void add(double power);  // P at the next step's end
  double value() const;
  // From two steps on: one step has only the trapezoid, whose O(h^3) error would stand out
  // against a method of order 4 or 6 (two steps give Simpson's rule, three and more Gregory's).
  bool accurate() const { return n_ >= 2; }
  void save(OutArchive& a) const;
  void load(InArchive& a);

 private:
  static constexpr int kDifferences = 4;
  double h_ = 0.0;
  long n_ = 0;                        // steps added
  double sum_ = 0.0;                  // P_0 / 2 + P_1 + ... + P_n / 2 without the halves' ends
  double first_[kDifferences + 1]{};  // P_0 ... P_4
  double last_[kDifferences + 1]{};   // P_n, P_{n-1}, ... (the newest first)
};

// max over the rows of |mu_i v| / (|mu_i|_1 |v|_inf): the normwise backward error of each
// constraint row, the smallest relative change of the row (1-norm) that v satisfies exactly.
// In [0, 1]; round-off leaves a few eps whatever the scale of mu or v (a blade offset of 1e15
// scales the terms of the sum and the norms alike), a velocity entirely across its constraint
// gives about 1. 0 when v = 0. Allocation-free.
double relative_residual(const sparse::RowPattern& pattern, const double* mu, ConstVecRef v);

// The hitches' length scale: the largest |d g / d theta| over the holonomic rows of mu(q) and
// the rotation columns (a planar body's theta, a rigid body's Omega): the distance from a
// body's centre to its hitch point. 0 when there is none (no hitch, general bodies only, or
// hitches at the centres): the gap is then not bounded. With a workspace, mu(q) is read from
// it (evaluated unless it holds it); without, a copy of mu is made (nnz(mu) doubles, once).
double hitch_lever_arm(const Model& model, ConstVecRef q, Workspace* ws);

// F(t, q)^T v, the power of the external forces (0 without them). force: n_v entries.
double external_power(const Model& model, double t, ConstVecRef q, ConstVecRef v, VecRef force);

// BlewUp with why in message: the energy error `error` (net of the work when `balance`) is past
// kEnergyBound after step `step` at time t; `advice` ends the message (what to change).
Status energy_blew_up(double error, bool balance, long step, double t, const std::string& advice,
                      std::string& message);
// BlewUp with why in message (check_constraints, once it tripped).
Status constraint_broken(double relative_residual, double gap, double lever_arm, long step, double t,
                         std::string& message);

// Ok, or BlewUp with why in message: the relative residual past kResidualBound, or the gap past
// kGapBound times the lever arm (when there is one), after step `step` at time t.
inline Status check_constraints(double relative_residual, double gap, double lever_arm, long step, double t,
                                std::string& message) {
  return relative_residual > kResidualBound || (lever_arm > 0.0 && gap > kGapBound * lever_arm)
             ? constraint_broken(relative_residual, gap, lever_arm, step, t, message)
             : Status::Ok;
}

// The run's guard against coordinates so large that a step's displacement is below their ulp
// (x = 1e15 never moves by steps of 0.01: its ulp is 0.125). Checked before the first step and
// every kEvery steps, O(n). Only coordinates that move count: |v_i| at least kMoving times the
// largest |v_j|, so that a velocity crossing zero, or at round-off, is not taken for lost motion
// (a coordinate this fast whose step rounds away loses at least a hundredth of the motion). Nor
// a coordinate that the whole run moves by at most an ulp (v = 1e-17 at x = 1 for t = 10: a body
// at round-off speed, which stopped the run as precision-loss although nothing is lost).
class PrecisionWatch {
 public:
  static constexpr long kEvery = 64;
  static constexpr double kMoving = 1e-2;
  static constexpr double kWarnDigits = 6.0;  // a step kept to fewer digits is warned about

  // speed_floor: velocities at or below it are round-off (a body at rest under a force), not motion;
  // span: the run's length in time (a coordinate it moves by at most an ulp does not count).
  PrecisionWatch(const Model& model, double speed_floor, double span);
  // Before step `step` (0: the start): whether it is due.
  static bool due(long step) { return step % kEvery == 0; }
  // With the velocity v (n_v entries; empty: not checked). Ok, or PrecisionLoss with why in message.
  Status check(ConstVecRef q, ConstVecRef v, double h, long step, std::string& message);
  const std::string& warning() const { return warning_; }  // the first seen, "" if none
  void save(OutArchive& a) const { a(warning_); }
  void load(InArchive& a) { a(warning_); }

 private:
  const Model& model_;
  double speed_floor_;
  double span_;
  std::string warning_;
};

}  // namespace nonholo::scenarios
