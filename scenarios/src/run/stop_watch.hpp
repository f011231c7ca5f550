#pragma once
// The stop conditions of a run (RunConfig::stop_when, stop_conditions; StopCondition in
// run_types.hpp): checked after the steps they are due at; where one holds, the first time it held
// since its last check is found by bisection on the interpolant between the two states.
#include <nonholo/archive.hpp>
#include <nonholo/model.hpp>
#include <nonholo/scenarios/run_types.hpp>

#include <limits>
#include <string>
#include <vector>

namespace nonholo::scenarios {

// A built-in condition ("x0>10", "hitch-angle>1.2", "gap>0.01": RunConfig::stop_when) for this
// model. Throws std::invalid_argument naming the text and what is wrong.
StopCondition built_in_stop_condition(const Model& model, const std::string& text);

class StopWatch {
 public:
  // The conditions of `config` for `model` (the built-in ones parsed: std::invalid_argument).
  StopWatch(const Model& model, const RunConfig& config);
  bool empty() const { return conditions_.empty(); }

  // At the start (t, q; v the velocity, n_v): true when a condition holds already.
  bool check_start(double t, ConstVecRef q, ConstVecRef v);
  // After step k (`last`: the run's last), with its state: true when a condition due now holds;
  // then fired() and t_stop() say which and when. A condition that throws: true, with failure().
  bool check(long k, bool last, double t, ConstVecRef q, ConstVecRef v);

  const std::string& fired() const { return fired_; }
  double t_stop() const { return t_stop_; }
  const std::string& failure() const { return failure_; }  // a condition threw: why

  // Checkpoints: the states last checked (the interpolant's left ends).
  void save(OutArchive& a) const;
  void load(InArchive& a);

 private:
  // The state each group of conditions was last checked at (one group per `every`).
  struct Checked {
    long every = 1;
    double t = std::numeric_limits<double>::quiet_NaN();
    Vector q, v;
  };
  bool holds(const StopCondition& c, double t, ConstVecRef q);  // false, with failure_, if it threw
  // The first time in (left.t, t] at which `c` holds, by bisection on the interpolant.
  double first_time(const StopCondition& c, const Checked& left, double t, ConstVecRef q, ConstVecRef v);
  void remember(Checked& c, double t, ConstVecRef q, ConstVecRef v);

  std::vector<StopCondition> conditions_;
  std::vector<int> group_;  // conditions_[i]'s entry of checked_
  std::vector<Checked> checked_;
  bool hermite_ = true;  // n_q == n_v: cubic Hermite in q and v; else linear in q
  Vector between_;       // an interpolated q
  std::string fired_, failure_;
  double t_stop_ = std::numeric_limits<double>::quiet_NaN();
};

}  // namespace nonholo::scenarios
