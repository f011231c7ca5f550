#pragma once
/// @file
/// Everything a thread needs to integrate one Model: every buffer sized once here, and its
/// own factorisation of C (for CHOLMOD, its own cholmod_common). One Workspace per thread;
/// the Model must outlive it. The buffers are scratch owned by the integrators. The entry
/// points take busy_flag() for each call: a second call while one runs (another thread, or a
/// model callback of the running step) is refused with Status::WorkspaceBusy (busy_flag.hpp).
/// The members below are the integrators' own and do not check it.
#include <nonholo/archive.hpp>
#include <nonholo/busy_flag.hpp>
#include <nonholo/model.hpp>
#include <nonholo/rattle_options.hpp>
#include <nonholo/sparse/banded_ldlt.hpp>
#include <nonholo/sparse/factorization.hpp>
#include <nonholo/sparse/message.hpp>
#include <nonholo/status.hpp>

#include <memory>
#include <vector>

namespace nonholo {

namespace detail {
struct ChainPartitions;  // core/src/step/chain/chain_partitions.hpp
}
class HeldCaches;

/// How a Workspace is built.
struct WorkspaceOptions {
  /// The factorisation of C. Auto picks by the pattern of C (sparse::resolve_backend), except
  /// that a chain of elements (Model::is_chain) always gets Banded: the step then streams it
  /// body by body.
  sparse::Backend backend = sparse::Backend::Auto;
  /// Room to restore the state when a composed step (RattleOptions::order 4 or 6) fails in
  /// one of its substeps: four more state-sized vectors. Turn off for order-2-only use of a
  /// very large model; a composed step on such a workspace fails with MethodNotApplicable.
  bool composed_steps = true;
  /// A second copy of mu for the midpoint DLA baseline (nonholo/dla.hpp): nnz(mu) values,
  /// 88 MB for a million-body chain. Turn off when only reflection steps run; DLA midpoint
  /// steps on such a workspace fail with MethodNotApplicable. (A model without its own bias
  /// gets the copy anyway: its bias by differences needs it.)
  bool dla_steps = true;
  /// Threads for one step of one chain (docs/design.md, "One chain on several threads"): the
  /// common chain of knife edges and hitches (ElementSet::hitched_chain; springs and thrusts
  /// too), with one-form or holonomic hitches, is split into this many partitions of
  /// consecutive bodies, one per thread, at construction (std::invalid_argument for fewer than
  /// 1, or for such a chain more than half its bodies). The partitions run on a pool of
  /// worker threads kept for the process (started here as needed; idle workers spin briefly
  /// after a step, then sleep); a step that finds the pool busy with another thread's step runs
  /// its partitions in turn on its own thread, with the same results. Thrust callbacks are
  /// called on the calling thread, before the others start. Other models run on one thread. Threads only pay
  /// where cores are free: not inside a batch, which already gives each core a trajectory
  /// (Workspace::set_team runs the partitions on fewer threads, with the same results).
  int threads = 1;
};

/// The most threads WorkspaceOptions::threads can give one step of `model`: half its bodies for
/// the common chain of knife edges and hitches (springs and thrusts allowed), else 1.
int max_step_threads(const Model& model);

/// One thread's buffers and factorisation for one Model (see workspace.hpp).
/// Cache-line aligned (and so padded): the workspaces of a batch's threads are written at every
/// step and must not share a cache line (measured: sharing one halved the 2-thread speed-up).
class alignas(128) Workspace {
 public:
  /// Sizes every buffer for `model` and builds the factorisation `options` asks for; `model`
  /// must outlive the workspace.
  explicit Workspace(const Model& model, const WorkspaceOptions& options = {});
  /// The workspace keeps a pointer to the model: one built from a temporary would dangle.
  explicit Workspace(const Model&& model, const WorkspaceOptions& options = {}) = delete;
  ~Workspace();

  const Model& model() const { return *model_; }  ///< the model it was built for
  /// The factorisation in use (see sparse::Backend); "none" for a model without one-forms.
  ///@{
  sparse::Backend backend() const;
  const char* backend_name() const;
  ///@}
  /// The threads a step of this model uses (WorkspaceOptions::threads where it applies, else 1):
  /// the partitions of its chain.
  int threads() const;
  /// The threads that run those partitions, 1 to threads() (initially threads()): fewer run
  /// them in turn, bit for bit the same results, without waiting at barriers for threads the
  /// machine has no free core for (the run's fallback when its cores are busy). Values out of
  /// range are clamped.
  ///@{
  void set_team(int threads);
  int team() const { return team_; }
  ///@}
  /// Why the last failed call failed ("" if it did not).
  const char* message() const { return message_.c_str(); }
  /// Held by the call that uses the workspace (busy_flag.hpp).
  BusyFlag& busy_flag() { return busy_; }

  // --- used by the integrators (nonholo/rattle.hpp, start.hpp, dynamics.hpp) --------------
  /// Evaluates mu at q into mu_values unless they already hold mu(q) (mu is a pure function
  /// of q, so the cache is keyed by the bits of q). NaN or Inf in mu is reported by the
  /// factorize() that follows (NonFiniteOneForms, naming the row and column).
  Status evaluate_one_forms(ConstVecRef q);
  /// Assembles C from mu_values and factorises it.
  Status factorize(double min_pivot_ratio);
  /// Makes the factorisation hold C(q): nothing to do when it already does (the step that
  /// arrived at q left it there), otherwise evaluate_one_forms(q) and factorize().
  Status factorize_at(ConstVecRef q, double min_pivot_ratio);
  /// lambda = C^-1 rhs after factorize().
  Status solve(const double* rhs, double* lambda);
  /// Records the message and returns status: `return ws.fail(Status::..., "...", ...);`
  Status fail(Status status, const char* format, ...) __attribute__((format(printf, 3, 4))) {
    va_list args;
    va_start(args, format);
    message_.vset(format, args);
    va_end(args);
    return status;
  }
  void clear_message() { message_.clear(); }  ///< message() becomes ""

  /// The next configuration and a configuration scratch (n_q entries) ...
  ///@{
  Vector q_next, scratch_q;
  ///@}
  /// ... scratch vectors of size n_v (velocities, momenta, forces) ...
  ///@{
  Vector p_half, p_hat, p_next, velocity, applied, force_next, scratch_n, scratch_n2;
  ///@}
  /// ... with rigid bodies (empty otherwise): the momentum the drift carries to q_{k+1} (the
  /// rigid bodies' p_Omega turned by W^T; p_half itself on flat models), and the gyroscopic
  /// term M^-1 g (n_v) with its image mu M^-1 g (m) ...
  ///@{
  Vector p_arrive, gyroscopic, gyroscopic_m;
  ///@}
  /// ... of size nnz(mu), nnz(C) and m (one-form rows). c_values holds C only for the
  /// factorisations without an in-place path (it is empty with CHOLMOD and banded);
  /// scratch_nnz2 is empty for a model with an analytic bias.
  ///@{
  Vector mu_values, c_values, rhs, lambda, scratch_m, scratch_nnz, scratch_nnz2;
  ///@}
  /// ... and of size num_holonomic() (hitch gaps g(q)).
  Vector gap;
  /// Position-level iterations taken by the last step in holonomic mode. Their corrections
  /// add (h/2) G to p_half (G = mu_k^T dlambda); lambda~_{k+1} then settles at lambda_s - x,
  /// not at lambda_s, with x = C^-1 mu M^-1 G/2 at q_{k+1} (m entries; restart_internal.hpp's
  /// gap_offset_multiplier computes it when the period-2 mode is measured or restarted).
  ///@{
  int gap_iterations = 0;
  Vector offset_multiplier;
  ///@}

  /// The period-2 mode (restart.hpp). lambda_s: the continuous multiplier lambda_s(q, p~) last
  /// computed (m); lambda_f: its part due to the applied force, -C^-1 mu M^-1 f (m, only for
  /// models with an applied force). With momentum maps, the restart also keeps their directions
  /// (map_pool, packed as map_slot says) and the split of p~ (map_probe, map_rest, map_linear: n;
  /// map_lambda0, map_lambda1: m; map_values: 2 maps, the maps' values J_j, then their scales).
  ///@{
  Vector lambda_s, lambda_f;
  Vector map_pool;
  Vector map_probe, map_rest, map_linear, map_lambda0, map_lambda1, map_values;
  ///@}
  /// Where each direction can be nonzero: entries [map_span[2j], map_span[2j+1]), whole blocks of
  /// M (a ball's spin touches its own body only: disjoint directions cost nothing to orthogonalise).
  std::vector<int> map_span;
  /// Direction j's entries k in [map_slot[3j+1], map_slot[3j+2]) are map_pool[map_slot[3j] + k -
  /// map_slot[3j+1]]: the widest its span can grow to (from the maps' supports, ModelBuilder::
  /// symmetry's `body`), so N spins and two rollings of a ball chain take 15 N doubles, not N n.
  std::vector<int> map_slot;
  /// The earlier directions whose slots overlap direction j's, ascending: map_overlap[
  /// map_overlap_ptr[j] ... map_overlap_ptr[j + 1]) (the only ones its Gram-Schmidt can meet).
  ///@{
  std::vector<int> map_overlap_ptr, map_overlap;
  ///@}
  /// What the last successful step found: the parasitic amplitude at its end (NaN when it was
  /// not measured) and whether it restarted the multipliers.
  ///@{
  double parasitic = 0.0;
  bool restarted = false;
  ///@}
  /// Composed steps: the state at the step's start, restored when a substep fails
  /// (WorkspaceOptions::composed_steps; empty otherwise).
  ///@{
  Vector saved_q, saved_p, saved_lambda, saved_force;
  ///@}
  /// Numeric factorisations of C so far (the unit of cost the methods are compared in).
  long factorizations = 0;
  /// Rigid bodies: the most Newton iterations a discrete Legendre transform has taken so far
  /// (0 for closed forms; reset it to watch a stretch of steps).
  int legendre_iterations = 0;
  /// The rotation Lagrangian of the last options step() accepted (MoserVeselov before any):
  /// what diagnose() and the restarts use to step back to q_{k-1} on models with rigid bodies.
  RotationLagrangian rotation() const { return options_known_ ? options_.rotation : RotationLagrangian::MoserVeselov; }
  /// Whether step() has found these options valid on this workspace before (it then skips its
  /// checks: on a small model they cost a tenth of a step), and remembering them.
  ///@{
  bool options_checked(const RattleOptions& o) const { return options_known_ && same_options(o, options_); }
  void remember_options(const RattleOptions& o) {
    options_ = o;
    options_known_ = true;
  }
  ///@}

  // --- the fused chain step (core/src/step/chain/chain_sweep.cpp) -----------------------
  /// Whether step() streams this model body by body: a chain of elements on the banded backend.
  bool fused() const { return banded_ != nullptr && chain_; }
  sparse::BandedLdlt* banded() { return banded_; }  ///< the factorisation when it is banded, else nullptr
  /// sin and cos of each body's angle at the last fused step's q (2 per body). In holonomic mode
  /// on the common chain (ElementSet::hitched_chain) the step swaps it with chain_sincos_prev,
  /// which then holds q_k's: the corrections build mu(q_k)'s rows from them (16 bytes a body
  /// read, not mu's 88, and no mu written by the sweep).
  ///@{
  Vector chain_sincos, chain_sincos_prev;
  ///@}
  /// The diagnostics of the state the last fused step produced, computed by its sweeps;
  /// `q` is that state's q buffer (nullptr when invalid). Read through diagnose_step().
  struct StepDiagnostics {
    const double* q = nullptr;  ///< the q buffer of the state they belong to (nullptr: none)
    long steps = -1;  ///< that state's step count
    /// As in Diagnostics.
    ///@{
    double energy = 0.0, energy_post = 0.0, residual = 0.0, gap = 0.0;
    ///@}
  } step_diagnostics;  ///< the last fused step's (see StepDiagnostics)
  /// The sweep writes mu(q) and q itself: it forgets the cached one-forms first, hands out the
  /// key buffer, and declares both valid (with C(q) factorised) when it succeeds.
  /// Without `mu_written` the values are filled from chain_sincos when first asked for
  /// (evaluate_one_forms): a one-form step does not need them, only a restart or diagnose().
  ///@{
  void forget_one_forms() { key_valid_ = mu_valid_ = factor_valid_ = sincos_valid_ = parted_ = false; }
  double* one_form_key() { return mu_q_.data(); }
  void forget_sincos() { sincos_valid_ = false; }  ///< chain_sincos reused for another q
  void one_forms_factorized_at_key(bool mu_written, bool parted = false) {
    key_valid_ = factor_valid_ = sincos_valid_ = true;
    mu_valid_ = mu_written;
    mu_from_sincos_ = false;
    parted_ = parted;
    ++factorizations;
  }
  /// The partitions of a chain split over threads (nullptr on one thread), and whether the
  /// factorisation is theirs (a partitioned step's: solve(), the mode's measurement and the
  /// holonomic passes then solve with it on the partitions).
  ///@{
  detail::ChainPartitions* partitions() { return partitions_.get(); }
  bool factor_parted() const { return parted_; }
  ///@}
  /// factorize_at(q), but C(q) factorised in the band's natural order (refactorised when a
  /// partitioned step left it partitioned): the holonomic corrections from a state no fused step
  /// arrived at (the first step, a resumed run) read it row by row.
  Status factorize_serial_at(ConstVecRef q, double min_pivot_ratio);
  ///@}
  /// Checkpoints (archive.hpp): what a step leaves for the next one, the one-forms, C(q)
  /// factorised and a chain's sines and cosines at the state's q, so that a resumed run's first
  /// step does what the uninterrupted run's did, bit for bit (a fresh factorisation of the same C
  /// is not bitwise the one a fused sweep builds row by row). Backends without exposed numbers
  /// (dense, CHOLMOD) factorise again at load, uncounted: theirs is the code the step uses.
  /// load_held throws std::runtime_error on bytes of another model or a factorisation that fails.
  ///@{
  void save_held(OutArchive& a) const;
  void load_held(InArchive& a, double min_pivot_ratio);
  ///@}
  /// A second trajectory on this workspace (the accuracy check's shadow, accuracy.hpp): what a
  /// step leaves for the next one of the same trajectory (HeldCaches) swapped in for its steps
  /// and out after them, every other buffer shared. make_held() sizes a set like this
  /// workspace's, holding nothing yet (it shares the workspace's scratch, a split chain's tail
  /// vector included: it must not outlive the workspace); swap_held() exchanges it with the
  /// workspace's own (pointers and flags), in for the visitor's steps, then out.
  /// On the common chain of knife edges and hitches (whose sweeps do not write mu) the set has no
  /// mu of its own (88 MB for a million bodies): the visitor writes the workspace's, and its
  /// values do not survive its visit; the owner's, if it held them, are made again on the way
  /// out from the sin/cos they were made from, bit for bit (one pass over mu). Where they were
  /// made otherwise (a resumed run's, read from its checkpoint), swapping in first gives the set
  /// a mu of its own, once (std::bad_alloc if that fails; nothing is swapped then).
  /// The key of mu (the q it belongs to) is after a step the q the step arrived at: given the two
  /// trajectories' q (`owner_q`, `visitor_q`: their states' q, nq entries each; the owner's does
  /// not change during the visit, the visitor's is on its way in what it was on its way out), the
  /// set keeps no key (24 MB for a million bodies): each side's is written back from its q when it
  /// comes back, and a visitor's key that is not its q on the way out is dropped (its next step
  /// evaluates mu afresh). Where the owner's key is not its q, or the q are not given, the set
  /// gets a key of its own, once, as for mu.
  ///@{
  HeldCaches make_held() const;
  void swap_held(HeldCaches& other, const double* owner_q = nullptr, const double* visitor_q = nullptr);
  ///@}
  /// Whether chain_sincos holds sin/cos of this q (the last fused step arrived there).
  bool sincos_hold(ConstVecRef q) const;
  /// ... and C(q) is factorised (one comparison of q; in natural order or partitioned).
  bool chain_factor_holds(ConstVecRef q) const { return factor_valid_ && sincos_hold(q); }
  /// chain_sincos now holds sin/cos of the q of the one-form cache (computed by the caller).
  void sincos_computed_for_key() { sincos_valid_ = key_valid_; }
  /// The Status and message of a failed factorisation (as factorize() reports it).
  Status report_factor_failure(sparse::FactorStatus status);

 private:
  const Model* model_;
  const bool chain_ = model_->is_chain();  // asked once (initialised before the constructor's body)
  std::unique_ptr<sparse::Factorization> factor_;
  sparse::BandedLdlt* banded_ = nullptr;  // factor_ when it is banded
  Vector mu_q_;            // the q of mu_values and of the factorisation, when key_valid_
  bool key_valid_ = false;
  bool mu_valid_ = false;     // mu_values holds mu(mu_q_)
  bool factor_valid_ = false;  // the factorisation holds C(mu(mu_q_))
  bool sincos_valid_ = false;  // chain_sincos holds sin/cos of mu_q_ (fused workspaces only)
  bool mu_from_sincos_ = false;  // mu_values were made from chain_sincos (so can be made again)
  bool parted_ = false;        // the factorisation is partitions_' (a partitioned step's)
  std::unique_ptr<detail::ChainPartitions> partitions_;
  int team_ = 1;               // set_team's
  bool options_known_ = false;  // options_ passed step()'s checks
  RattleOptions options_;
  Status report_non_finite_one_forms();
  void set_up_threads(int threads);
  // spare_rows: room after a chain's band for its tail partition's (ChainPartitions).
  std::unique_ptr<sparse::Factorization> new_factor(sparse::Backend backend, int spare_rows) const;
  // " (row r is <label>)" for a labelled row of mu or C, "" otherwise; no allocation.
  const char* row_note(int row);
  char row_note_[256] = "";
  sparse::Message message_;
  BusyFlag busy_;
};

/// What a step leaves in a Workspace for the next step of the same trajectory, and nothing else:
/// mu(q) and the q it belongs to, C(q) factorised (with a chain's partitions' numbers), a
/// chain's sines and cosines, the last fused step's diagnostics, the counters (factorizations,
/// legendre_iterations, parasitic, restarted) and the options last accepted. Every other buffer
/// of a Workspace is scratch that a step writes before it reads. A second trajectory stepped on
/// the same workspace keeps its own set here (Workspace::make_held, swap_held): the accuracy
/// check's shadow needs no second copy of the scratch (for a million-body chain about 0.4 GB of
/// the 0.64 GB a workspace holds). Move-only; empty until made by make_held().
class HeldCaches {
 public:
  HeldCaches();   ///< empty (Workspace::make_held makes a usable one)
  ~HeldCaches();  ///< frees the factorisation and the buffers
  /// Moved, not copied: the factorisation is owned.
  ///@{
  HeldCaches(HeldCaches&&) noexcept;
  HeldCaches& operator=(HeldCaches&&) noexcept;
  ///@}

 private:
  friend class Workspace;
  void forget() { key_valid_ = mu_valid_ = factor_valid_ = sincos_valid_ = parted_ = false; }  // as forget_one_forms()
  std::unique_ptr<sparse::Factorization> factor_;
  std::unique_ptr<detail::ChainPartitions> partitions_;
  // chain_sincos_prev is scratch within a holonomic step: the workspace's serves both sets.
  Vector mu_q_, mu_values_, chain_sincos_;
  bool key_valid_ = false, mu_valid_ = false, factor_valid_ = false, sincos_valid_ = false, parted_ = false;
  bool mu_from_sincos_ = false;
  bool shares_mu_ = false;  // no mu_values_: the visitor writes the workspace's (see Workspace::swap_held)
  bool shares_key_ = false;  // no mu_q_: each side's key written back from its q (Workspace::swap_held)
  bool visiting_ = false;   // swapped in now
  Workspace::StepDiagnostics step_diagnostics_;
  long factorizations_ = 0;
  int legendre_iterations_ = 0;
  double parasitic_ = 0.0;
  bool restarted_ = false;
  bool options_known_ = false;
  RattleOptions options_;
};

}  // namespace nonholo
