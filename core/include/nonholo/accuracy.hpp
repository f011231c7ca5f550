#pragma once
/// @file
/// A cheap estimate of a run's global error in q, on by default in `nonholo run` (README
/// "Accuracy check"). Every `every` steps one pair of steps is sampled: besides the run's two
/// steps of h from x_k, a shadow takes ONE step of 2h from x_k (on the run's workspace with its
/// own HeldCaches, and its own state, so the run is bit for bit the same with and without the
/// watch). For a method of order p the
/// difference is (2^(p+1) - 2) times the local error of one step of h, to leading order
/// (step doubling). The local errors are accumulated into a global estimate (GlobalError).
#include <nonholo/archive.hpp>
#include <nonholo/model.hpp>
#include <nonholo/rattle_options.hpp>
#include <nonholo/state.hpp>
#include <nonholo/status.hpp>
#include <nonholo/workspace.hpp>

#include <limits>
#include <memory>
#include <string>

namespace nonholo {

/// Local errors to a global one. Each sample says that the steps around it made local errors
/// dq in q and dv in the velocity M^-1 p per step (max norms). Errors in q are carried forward as
/// they are; an error in the velocity drifts the configuration by (t - t_w) dv after it, as in
/// free motion. So at time t
/// ~~~{.unparsed}
///   E(t) = sum_w n_w (dq_w + (t - t_w) dv_w)
/// ~~~
/// over the stretches w of n_w steps at time t_w, kept as three running sums (no history). It
/// neither damps errors (the sleigh's attracting straight line) nor amplifies them (an unstable
/// chain); README's table says how it tracks the true error.
class GlobalError {
 public:
  /// A stretch of `steps` steps around time t, each with local errors dq in q and dv in the
  /// velocity.
  void add(double t, double steps, double dq, double dv) {
    q_sum_ += steps * dq;
    v_sum_ += steps * dv;
    tv_sum_ += steps * dv * t;
  }
  /// E(t): the global error in q at time t of the stretches added so far.
  double at(double t) const { return q_sum_ + t * v_sum_ - tv_sum_; }
  /// Checkpoints (archive.hpp): the three running sums.
  ///@{
  void save(OutArchive& a) const { a(q_sum_), a(v_sum_), a(tv_sum_); }
  void load(InArchive& a) { a(q_sum_), a(v_sum_), a(tv_sum_); }
  ///@}

 private:
  double q_sum_ = 0.0, v_sum_ = 0.0, tv_sum_ = 0.0;
};

/// The range each coordinate of q has swept over the states included: the extent of a motion (its
/// widest range, the scale the accuracy check judges against) and the largest |q_i| (the round-off
/// floor of a motion with no extent), each with the current q counted too.
class Extent {
 public:
  explicit Extent(Eigen::Index nq = 0);  ///< for nq coordinates, nothing included yet
  void include(ConstVecRef q);             ///< q into the range
  double extent(ConstVecRef q_now) const;  ///< the widest range, q_now counted too
  double largest_coordinate(ConstVecRef q_now) const;  ///< the largest |q_i|, q_now counted too
  Eigen::Index size() const { return min_.size(); }    ///< the coordinates (0: not sized yet)
  /// Checkpoints (archive.hpp): both bounds (an Extent of size 0 takes the stored size; one
  /// sized by its model refuses another).
  ///@{
  void save(OutArchive& a) const { a(min_), a(max_); }
  void load(InArchive& a);
  ///@}

 private:
  Vector min_, max_;
};

/// (2^(p+1) - 2): the step-doubling difference of a method of order p in units of its local error.
double doubling_factor(int order);

/// The accuracy check's companion to an estimate of a run's global error in q. The companion is a
/// second trajectory of the same start whose error is `ratio` times the run's to leading order
/// (the same method of order p at 2h: 2^p; adaptive steps at 10 tol: about 10), integrated
/// alongside; `difference` is the largest |q - q_companion|_inf seen. Richardson: the run's error
/// is difference / |ratio - 1|. That holds while both are in the asymptotic regime, which the
/// companion, the less accurate of the two, leaves first: where its own error (ratio times the
/// estimate) exceeds `allowed` (the tolerance the run is judged against), the estimate is 3 times
/// Richardson's (Roache's factor of safety for a two-level study). Measured on 40 hard cases
/// (docs/guide/methods.md "Accuracy check"): no run more than 10 % of its extent off passes, where
/// Richardson alone let a chaotic chain 49 % off through at 8.5 %.
double companion_estimate(double difference, double ratio, double allowed);

/// The method-independent part of the check: when to sample, how a sample's differences become
/// local errors, and their sum; the extent of the motion. A method's watch (AccuracyWatch for the
/// reflection step; the RK4 runner's, with reference::Integrator::rk4_trial) takes the shadow steps
/// and feeds it.
///
/// every: the most steps between the starts of two samples (even, at least 2). Sampling starts
/// dense (a pair every 2 steps) and spreads out, doubling the interval up to `every` while
/// consecutive samples agree within a factor 4, and quartering it when they do not (a transient,
/// the start's): a stretch between two samples is counted with their mean. A sample costs about
/// one step of 2h and a factorisation: about 2/every of the run once spread out.
class DoublingEstimate {
 public:
  /// For a configuration of nq entries and a method of order `order`; throws
  /// std::invalid_argument unless `every` is even and at least 2.
  DoublingEstimate(Eigen::Index nq, int order, int every);

  /// Before the run's step: whether the shadow's step of 2h should start now (then call
  /// include() with the configuration, and started(), started_single() or failed()). Inline: it
  /// runs every step.
  bool due() const { return pending_at_ < 0 && step_ >= next_at_; }
  bool pending() const { return pending_at_ >= 0; }  ///< a shadow's pair under way
  void include(ConstVecRef q);  ///< into the extent
  /// The shadow's step of 2h succeeded: the pair ends after the run's next two steps.
  void started() { pending_at_ = step_ + 2; }
  /// The shadow's step of 2h from time t failed with `status` (its name) and `message`: counted,
  /// the first one kept (first_failure()), and the next sample tried `every` steps later, unless
  /// a retry starts (started_single()).
  void failed(double t, const char* status, const char* message);
  /// After failed(): the shadow took two steps of h/2 instead, and the sample ends after the run's
  /// next step (one step of h against two of h/2: the difference is (1 - 2^-p) local errors).
  void started_single() {
    pending_at_ = step_ + 1;
    single_ = true;
  }
  /// After the run's step to (t, q): whether it ends a pair (then call sample()). q must stay
  /// alive and in place until the next call (the run's own state).
  bool stepped(double t, ConstVecRef q) {
    ++step_;
    t_ = t;
    last_q_ = q.data();
    if (pending_at_ != step_) return false;
    pending_at_ = -1;
    return true;
  }
  /// The pair's differences, shadow minus run, in q and in the velocity (max norms), the run's
  /// speed |v|_inf and largest |q_i|, at the pair's end t with the run's step h.
  void sample(double t, double h, double dq, double dv, double speed, double q_norm);

  /// The global error estimate in q at the last step's time (max norm, the units of q); the steps
  /// since the last sample are counted at its rate.
  double estimate() const;
  /// The scale the estimate is judged against: the widest range any coordinate of q has swept
  /// (max - min over the samples' states and the last state), the extent of the motion in the
  /// units of q; and the largest |q_i| seen, for the round-off floor of a motion with no extent.
  ///@{
  double extent() const;
  double largest_coordinate() const;
  ///@}
  /// The largest local error per step seen (q part), and the number of samples taken.
  ///@{
  double local_max() const { return local_max_; }
  long samples() const { return samples_; }
  ///@}
  long failed_samples() const { return failed_; }  ///< shadow steps of 2h that failed (failed())
  long single_samples() const { return singles_; }  ///< of those, retried as two of h/2 (started_single())
  /// Samples outside step doubling's asymptotic regime (velocities of the step of 2h and the two
  /// of h differing by more than 1 % of the speed, and the next sample a hundred times quieter: a
  /// transient faster than the step), counted whole; and the time of the first. Their error falls
  /// more slowly than h^p.
  ///@{
  long transient_samples() const { return transients_; }
  double first_transient() const { return first_transient_t_; }
  ///@}
  /// Samples whose velocities differed by more than 1 % of the speed: outside step doubling's (and
  /// Richardson's) asymptotic regime, transient or not.
  long fast_samples() const { return fast_; }
  /// "t = 1.23: gap-not-converged: ..." for the first shadow step of 2h that failed.
  const std::string& first_failure() const { return first_failure_; }

  /// Checkpoints (archive.hpp): every field; after load(), rebind() to the run's configuration
  /// (what stepped() would have seen last).
  ///@{
  void save(OutArchive& a) const;
  void load(InArchive& a);
  void rebind(ConstVecRef q) { last_q_ = q.data(); }
  ///@}

 private:
  int every_;
  double factor_;
  Extent range_;          // the range each coordinate has swept, at the samples
  GlobalError error_;
  long step_ = 0;         // steps of the run seen so far
  long pending_at_ = -1;  // the run's step count when the shadow's pair ends (-1: none)
  long next_at_ = 0;      // the step at which the next sample starts
  long interval_ = 2;     // steps between the starts of two samples, 2 ... every
  long last_end_ = -1;    // the step at which the last sample's pair ended (-1: none yet)
  double last_dq_ = 0.0, last_dv_ = 0.0, last_t_ = 0.0;  // its local errors and time
  bool last_fast_ = false;  // its velocities differed by more than 1 % of the speed
  double t_ = 0.0, local_max_ = 0.0;
  long samples_ = 0, failed_ = 0, transients_ = 0, fast_ = 0;
  double first_transient_t_ = 0.0;
  const double* last_q_ = nullptr;  // the configuration stepped() last saw
  std::string first_failure_;
  double single_factor_;  // 1 - 2^-p: a single step's difference in units of its local error
  bool single_ = false;   // the sample under way is one step of h against two of h/2
  long singles_ = 0;
};

/// The sampled step doubling of the reflection step (orders 2, 4, 6; a composed step counts as
/// one step of H). The shadow steps on the run's workspace: its scratch is shared (a shadow step
/// never overlaps a run step), and what a step leaves for the next one is swapped for the
/// shadow's own (HeldCaches) around each shadow step, so the run's workspace is left holding what
/// it held. Besides that set, the watch keeps the shadow's state (all of it: a retry's two steps
/// of h/2 step on from the shadow's own) and the extent's range of q.
/// Both are made at the first sample (the only allocations), or by prepare(). The shadow never
/// changes the run's state or what its workspace holds for the next step.
class AccuracyWatch {
 public:
  /// Watches a run stepped on `run` with these step options, sampling at most every `every`
  /// steps (DoublingEstimate). The workspace (and its model) must outlive the watch, and the
  /// run's steps and the watch's calls take turns on it (before_step, step, after_step).
  AccuracyWatch(Workspace& run, const RattleOptions& options, int every);
  /// The same with a workspace of the watch's own for the shadow, built with `workspace` (the
  /// same estimates, bit for bit; the run may then step on any workspace). The model must
  /// outlive the watch.
  AccuracyWatch(const Model& model, const WorkspaceOptions& workspace, const RattleOptions& options, int every);
  AccuracyWatch(const Model&& model, const WorkspaceOptions&, const RattleOptions&, int) = delete;

  /// Call before each step of the run, with the state it starts from, and after it with the new
  /// state. Never throws; a shadow step of 2h that fails is counted (failed_samples(),
  /// first_failure()) and retried as two steps of h/2 against the run's one (single_samples()):
  /// a failed step never counts as agreement.
  ///@{
  void before_step(State& s) {
    if (estimate_.due()) start_shadow(s);
  }
  void after_step(const State& s) {
    if (estimate_.stepped(s.t, s.q)) finish_shadow(s);
  }
  ///@}

  /// Makes the shadow's state and caches now instead of at the first sample: a run that times
  /// its steps apart from its set-up calls it in the set-up (nonholo run does).
  void prepare() {
    if (!held_made_) make_shadow();
  }

  /// The estimate so far and its counters.
  const DoublingEstimate& estimate() const { return estimate_; }

  /// The threads that run the shadow's partitions on a workspace of its own (Workspace::set_team;
  /// the same results); on the run's, its team is the run's.
  void set_team(int threads) {
    if (own_) own_->set_team(threads);
  }

  /// Checkpoints: the estimate and the shadow's state (a sample may be under way); after load(),
  /// rebind() to the run's state.
  ///@{
  void save(OutArchive& a) const;
  void load(InArchive& a);
  void rebind(const State& s) { estimate_.rebind(s.q); }
  ///@}

 private:
  void make_shadow();
  Status shadow_step(const State& s, const RattleOptions& o, bool from_run);
  void start_shadow(State& s);
  void finish_shadow(const State& s);
  const Model& model_;
  std::unique_ptr<Workspace> own_;  // the shadow's own workspace, if it has one
  Workspace& ws_;                   // the run's, or own_
  HeldCaches held_;                 // the shadow's, made at the first sample
  bool held_made_ = false;
  RattleOptions options_;  // h doubled
  RattleOptions halved_;   // h halved: the retry of a step of 2h that failed
  State shadow_;
  DoublingEstimate estimate_;
};

// (No watch for the DLA baselines: their state (q_k, p_{k-1/2}) is staggered by half a step, so
// a step of 2h from it is not the method at 2h: its difference measured the stagger, 2.4 on the
// sleigh where the error is 7e-5.)

}  // namespace nonholo
