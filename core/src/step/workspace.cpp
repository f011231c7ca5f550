// Workspace (workspace.hpp): buffers sized once and C's backend chosen, mu(q) cached by q, C assembled,
// factorised and solved with named failures, and the caches a checkpoint keeps.
#include <nonholo/workspace.hpp>

#include <nonholo/sparse/big_buffer.hpp>

#include "step/restart_internal.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <stdexcept>
#include <string>
#include <utility>

#include "base/thread_team.hpp"
#include "model/element_set.hpp"
#include "step/chain/ball_chain_band.hpp"
#include "step/chain/chain_partitions.hpp"
#include "step/chain/chain_sweep.hpp"

namespace nonholo {
namespace {
// A ball chain's C is banded by its layout (ElementSet::ball_chain): no pattern, no Gram.
bool ball_chain(const Model& model) {
  return model.num_one_forms() > 0 && model.element_set() && model.element_set()->ball_chain;
}
}  // namespace

Workspace::Workspace(const Model& model, const WorkspaceOptions& options) : model_(&model) {
  const int n = model.num_velocities(), nq = model.num_configuration(), m = model.num_one_forms();
  for (Vector* v : {&q_next, &scratch_q, &mu_q_}) sparse::zero_buffer(*v, nq);
  for (Vector* v : {&p_half, &p_hat, &p_next, &velocity, &applied, &force_next, &scratch_n, &scratch_n2})
    sparse::zero_buffer(*v, n);
  if (model.has_rigid_bodies()) {
    sparse::zero_buffer(p_arrive, n);
    sparse::zero_buffer(gyroscopic, n);
    sparse::zero_buffer(gyroscopic_m, m);
  }
  sparse::zero_buffer(mu_values, model.num_one_form_values());
  // The bias by central differences needs two more copies of mu (dynamics.cpp), the midpoint
  // DLA one; a model with its own bias (every element model) stepped by reflections none:
  // 176 MB less for a million-body chain.
  if (!model.has_analytic_bias() || options.dla_steps) sparse::zero_buffer(scratch_nnz, model.num_one_form_values());
  if (!model.has_analytic_bias()) sparse::zero_buffer(scratch_nnz2, model.num_one_form_values());
  sparse::zero_buffer(rhs, m);
  sparse::zero_buffer(lambda, m);
  sparse::zero_buffer(scratch_m, m);
  sparse::zero_buffer(gap, model.num_holonomic());
  if (m > 0) sparse::zero_buffer(lambda_s, m);
  if (model.num_holonomic() > 0) sparse::zero_buffer(offset_multiplier, m);
  if (m > 0 && model.has_applied_force()) sparse::zero_buffer(lambda_f, m);
  const int maps = static_cast<int>(model.momentum_maps().size());
  if (m > 0 && maps > 0) {
    sparse::zero_buffer(map_pool, detail::plan_map_slots(model, map_slot, map_overlap_ptr, map_overlap));
    for (Vector* v : {&map_probe, &map_rest, &map_linear}) sparse::zero_buffer(*v, n);
    sparse::zero_buffer(map_lambda0, m);
    sparse::zero_buffer(map_lambda1, m);
    sparse::zero_buffer(map_values, 2 * maps);  // J_j, then the scale each is checked against
    map_span.assign(2 * static_cast<std::size_t>(maps), 0);
  }
  if (options.composed_steps) {
    sparse::zero_buffer(saved_q, nq);
    sparse::zero_buffer(saved_p, n);
    sparse::zero_buffer(saved_force, n);
    sparse::zero_buffer(saved_lambda, m);
  }
  sparse::Backend backend = options.backend;
  if (backend == sparse::Backend::Auto && (model.is_chain() || ball_chain(model))) backend = sparse::Backend::Banded;
  // A chain split over threads keeps its tail partition's band in the last rows of its own,
  // which the split leaves unused, and two more (the tail's copy of its left separator's rows).
  factor_ = new_factor(backend, options.threads > 1 ? detail::kTailSpareRows : 0);
  if (factor_ && factor_->backend() == sparse::Backend::Banded) banded_ = static_cast<sparse::BandedLdlt*>(factor_.get());
  if (fused()) sparse::zero_buffer(chain_sincos, 2 * model.num_bodies());
  if (fused() && model.element_set()->hitched_chain) sparse::zero_buffer(chain_sincos_prev, 2 * model.num_bodies());
  // CHOLMOD receives C straight into its own matrix; the others read it from c_values.
  if (factor_ && !factor_->values_in_place()) sparse::zero_buffer(c_values, model.gram().pattern().nnz());
  set_up_threads(options.threads);
}

Workspace::~Workspace() = default;

// A chain's band is set up from its layout: its C's pattern and index map (Model::gram) are not
// built unless another backend is forced.
std::unique_ptr<sparse::Factorization> Workspace::new_factor(sparse::Backend backend, int spare_rows) const {
  const int m = model_->num_one_forms();
  if (m > 0 && (model_->is_chain() || ball_chain(*model_)) && backend == sparse::Backend::Banded)
    return std::make_unique<sparse::BandedLdlt>(m, model_->element_set()->chain_bandwidth, spare_rows);
  if (m > 0) return sparse::make_factorization(backend, model_->gram().pattern());
  return nullptr;
}

HeldCaches::HeldCaches() = default;
HeldCaches::~HeldCaches() = default;
HeldCaches::HeldCaches(HeldCaches&&) noexcept = default;
HeldCaches& HeldCaches::operator=(HeldCaches&&) noexcept = default;

HeldCaches Workspace::make_held() const {
  HeldCaches h;
  if (factor_) h.factor_ = new_factor(factor_->backend(), banded_ ? banded_->spare_rows() : 0);
  if (partitions_)
    h.partitions_ = std::make_unique<detail::ChainPartitions>(
        model_->num_bodies(), partitions_->parts, static_cast<int>(model_->element_set()->thrusts.size()),
        static_cast<sparse::BandedLdlt*>(h.factor_.get()), partitions_->tail_x);
  // The common chain's sweeps leave mu unwritten (chain_sweep.cpp): its values, when asked for,
  // are made from the sin/cos the set keeps, so one buffer serves both sets (swap_held).
  h.shares_mu_ = fused() && model_->element_set()->hitched_chain;
  // The key after a step is the q it arrived at: restored from the two states' q (swap_held).
  h.shares_key_ = true;
  sparse::zero_buffer(h.chain_sincos_, chain_sincos.size());
  if (!h.shares_mu_) sparse::zero_buffer(h.mu_values_, mu_values.size());
  return h;
}

void Workspace::swap_held(HeldCaches& h, const double* owner_q, const double* visitor_q) {
  using std::swap;
  const bool in = !h.visiting_;
  const std::size_t key_bytes = sizeof(double) * static_cast<std::size_t>(mu_q_.size());
  // Coming in to a workspace whose mu cannot be made again as it is (not from its sin/cos): the
  // set's own buffer, once (before anything is swapped, so a failed allocation changes nothing).
  if (in && h.shares_mu_ && key_valid_ && mu_valid_ && !(mu_from_sincos_ && sincos_valid_)) {
    sparse::zero_buffer(h.mu_values_, mu_values.size());
    h.shares_mu_ = false;
  }
  // Likewise the key, where the owner's is not its q (or the two q are not given); the visitor's,
  // if valid, is its q (kept so on its way out), and is lost where that q is not given.
  if (in && h.shares_key_ &&
      (!owner_q || !visitor_q || (key_valid_ && std::memcmp(mu_q_.data(), owner_q, key_bytes) != 0))) {
    sparse::zero_buffer(h.mu_q_, mu_q_.size());
    h.shares_key_ = false;
    if (visitor_q && h.key_valid_)
      std::memcpy(h.mu_q_.data(), visitor_q, key_bytes);
    else
      h.forget();
  }
  if (in && h.shares_key_ && h.key_valid_) std::memcpy(mu_q_.data(), visitor_q, key_bytes);
  h.visiting_ = in;
  swap(factor_, h.factor_);
  banded_ = factor_ && factor_->backend() == sparse::Backend::Banded ? static_cast<sparse::BandedLdlt*>(factor_.get())
                                                                     : nullptr;
  swap(partitions_, h.partitions_);
  if (!h.shares_key_) mu_q_.swap(h.mu_q_);
  if (!h.shares_mu_) mu_values.swap(h.mu_values_);
  chain_sincos.swap(h.chain_sincos_);
  swap(key_valid_, h.key_valid_);
  swap(mu_valid_, h.mu_valid_);
  swap(mu_from_sincos_, h.mu_from_sincos_);
  swap(factor_valid_, h.factor_valid_);
  swap(sincos_valid_, h.sincos_valid_);
  swap(parted_, h.parted_);
  swap(step_diagnostics, h.step_diagnostics_);
  swap(factorizations, h.factorizations_);
  swap(legendre_iterations, h.legendre_iterations_);
  swap(parasitic, h.parasitic_);
  swap(restarted, h.restarted_);
  swap(options_known_, h.options_known_);
  swap(options_, h.options_);
  if (!in && h.shares_key_) {  // the visitor's key kept as its q, if it is; the owner's put back
    if (h.key_valid_ && (!visitor_q || std::memcmp(mu_q_.data(), visitor_q, key_bytes) != 0))
      h.forget();
    if (key_valid_ && owner_q)
      std::memcpy(mu_q_.data(), owner_q, key_bytes);
    else  // the q not given on the way out as on the way in: the owner evaluates mu afresh
      forget_one_forms();
  }
  if (!in && h.shares_mu_) {  // the visitor's values are lost with its visit; the owner's made again
    h.mu_valid_ = false;
    if (key_valid_ && mu_valid_) detail::chain_one_forms_from_sincos(*model_, *this);
  }
}

// One chain on several threads (chain_partitions.hpp): the common chain of knife edges and hitches.
void Workspace::set_up_threads(int threads) {
  if (threads < 1)
    throw std::invalid_argument("WorkspaceOptions::threads = " + std::to_string(threads) + ": give 1 or more");
  const detail::ElementSet* set = model_->element_set();
  if (threads == 1 || !fused() || !set || !set->hitched_chain) return;  // a step not split: one thread
  const int bodies = model_->num_bodies(), limit = max_step_threads(*model_);
  if (threads > limit)
    throw std::invalid_argument("WorkspaceOptions::threads = " + std::to_string(threads) + " for " +
                                std::to_string(bodies) + " bodies: each thread needs at least 2 bodies, so at most " +
                                std::to_string(limit) + (limit == 1 ? " thread" : " threads"));
  if (threads > detail::ThreadPool::kMaxTeam)
    throw std::invalid_argument("WorkspaceOptions::threads = " + std::to_string(threads) + ": at most " +
                                std::to_string(detail::ThreadPool::kMaxTeam) + " threads run one chain");
  partitions_ =
      std::make_unique<detail::ChainPartitions>(bodies, threads, static_cast<int>(set->thrusts.size()), banded_);
  detail::ThreadPool::reserve(threads);  // the team's workers, kept for the process (thread_team.hpp)
  team_ = threads;
}

int Workspace::threads() const { return partitions_ ? partitions_->parts : 1; }

void Workspace::set_team(int threads) { team_ = std::max(1, std::min(threads, this->threads())); }

int max_step_threads(const Model& model) {
  const detail::ElementSet* set = model.element_set();
  const bool chain = model.is_chain() && model.num_one_forms() > 0 && set && set->hitched_chain;
  return chain ? std::max(1, model.num_bodies() / 2) : 1;
}

sparse::Backend Workspace::backend() const {
  return factor_ ? factor_->backend() : sparse::Backend::Auto;
}

const char* Workspace::backend_name() const {
  return factor_ ? sparse::to_string(factor_->backend()) : "none";
}

Status Workspace::evaluate_one_forms(ConstVecRef q) {
  const int n = model_->num_configuration();
  if (key_valid_ && std::memcmp(q.data(), mu_q_.data(), sizeof(double) * n) == 0) {
    if (!mu_valid_) {  // a fused step factorised C(q) without writing mu: it left sin/cos
      if (sincos_valid_)
        detail::chain_one_forms_from_sincos(*model_, *this);
      else  // a holonomic correction since reused chain_sincos for q_{k+1}
        model_->one_form_values(q, mu_values);
      mu_valid_ = true;
      mu_from_sincos_ = sincos_valid_;
    }
    return Status::Ok;
  }
  key_valid_ = mu_valid_ = factor_valid_ = sincos_valid_ = parted_ = false;
  if (model_->num_one_forms() == 0) return Status::Ok;
#ifndef NDEBUG
  // Debug builds: a value function that fills too few values leaves NaN, which factorize()
  // reports with its row and column (release builds check this once, at the start).
  mu_values.setConstant(std::numeric_limits<double>::quiet_NaN());
#endif
  // NaN or Inf in mu reaches a diagonal entry of C, so factorize() finds it; the scan that
  // names the entry runs only then (one pass less over mu in every step). The key is set only
  // after the values: a callback that throws leaves no key behind.
  if (fused()) {  // a chain: sin/cos once per body (the rows' own values take each 2-5 times),
    // kept for the bias at the same q (one_form_bias): the reference integrators' right-hand
    // side, the starts and the projections cost what the step's own passes cost
    detail::chain_sincos_of(*model_, q, chain_sincos);
    detail::chain_one_forms_from_sincos(*model_, *this);
  } else {
    model_->one_form_values(q, mu_values);
  }
  mu_q_ = q;
  key_valid_ = mu_valid_ = true;
  sincos_valid_ = mu_from_sincos_ = fused();
  return Status::Ok;
}

void Workspace::save_held(OutArchive& a) const {
  a.tag("workspace");
  a(key_valid_), a(mu_valid_), a(factor_valid_), a(sincos_valid_);
  if (key_valid_) a(mu_q_);
  if (mu_valid_) a(mu_values);
  if (sincos_valid_) a(chain_sincos);
  // A partitioned factorisation is not saved: the loading workspace factorises again.
  const sparse::Factorization::NumericState numbers =
      factor_valid_ && !parted_ && factor_ ? factor_->numeric_state() : sparse::Factorization::NumericState{};
  a(numbers.data != nullptr);
  if (numbers.data) a(Eigen::Map<const Vector>(numbers.data, static_cast<Eigen::Index>(numbers.size)));
}

void Workspace::load_held(InArchive& a, double min_pivot_ratio) {
  a.tag("workspace");
  bool key = false, mu = false, factor = false, sincos = false, numbers = false;
  a(key), a(mu), a(factor), a(sincos);
  forget_one_forms();
  if (key) a(mu_q_);
  if (mu) a(mu_values);
  if (sincos) a(chain_sincos);
  a(numbers);
  const sparse::Factorization::NumericState state = factor_ ? factor_->numeric_state() : sparse::Factorization::NumericState{};
  if (numbers) {
    if (!state.data) throw std::runtime_error("checkpoint: its factorisation is of a banded backend, this run's is not");
    a(Eigen::Map<Vector>(state.data, static_cast<Eigen::Index>(state.size)));
  }
  key_valid_ = key;
  mu_valid_ = mu;
  sincos_valid_ = sincos;
  mu_from_sincos_ = false;  // read back: not known to be made from the sin/cos
  if (factor && !numbers) {  // factorise again (the step's own code for these backends), uncounted
    if (key && !mu && sincos && fused()) {  // a partitioned step's: mu from its sin/cos
      detail::chain_one_forms_from_sincos(*model_, *this);
      mu = true;
      mu_from_sincos_ = true;
    }
    const long counted = factorizations;
    const Status s = key && mu ? factorize(min_pivot_ratio) : Status::Ok;
    factorizations = counted;
    if (s != Status::Ok) throw std::runtime_error(std::string("checkpoint: the saved state does not factorise: ") + message());
    factor = key && mu;
  }
  factor_valid_ = factor;
}

bool Workspace::sincos_hold(ConstVecRef q) const {
  return sincos_valid_ && key_valid_ &&
         std::memcmp(q.data(), mu_q_.data(), sizeof(double) * model_->num_configuration()) == 0;
}

Status Workspace::report_non_finite_one_forms() {
  const auto& pattern = model_->one_form_pattern();
  for (int r = 0; r < pattern.rows; ++r)
    for (int k = pattern.row_ptr[r]; k < pattern.row_ptr[r + 1]; ++k)
      if (!std::isfinite(mu_values[k]))
        return fail(Status::NonFiniteOneForms,
                    "one-form row %d%s, column %d (%s) has value %g: check the model's one-form "
                    "values at this q, or reduce the step size if the state blew up",
                    r, row_note(r), pattern.col_idx[k], model_->velocity_name(pattern.col_idx[k]).c_str(),
                    mu_values[k]);
  return fail(Status::NonFiniteOneForms, "%s%s: the state or the one-forms are not finite: reduce the step size",
              factor_->message(), row_note(factor_->failed_row()));
}

const char* Workspace::row_note(int row) {
  const std::string_view label = row >= 0 ? model_->row_label_view(row) : std::string_view();
  if (label.empty()) return "";
  std::snprintf(row_note_, sizeof row_note_, " (row %d is %.*s)", row, static_cast<int>(label.size()), label.data());
  return row_note_;
}

Status Workspace::factorize(double min_pivot_ratio) {
  if (!factor_) return Status::Ok;
  using sparse::FactorStatus;
  factor_valid_ = parted_ = false;
  ++factorizations;
  FactorStatus s;
  if (fused()) {  // a chain: its rows straight into the band (chain_passes.cpp)
    s = detail::factorize_chain(*model_, *this, min_pivot_ratio);
  } else if (banded_ && ball_chain(*model_)) {  // likewise (ball_chain_band.cpp)
    s = detail::factorize_ball_chain(*model_, *this, min_pivot_ratio);
  } else if (double* in_place = factor_->values_in_place()) {  // CHOLMOD: assemble into its own matrix
    model_->gram().assemble(mu_values.data(), in_place, factor_->slot_positions());
    s = factor_->factorize_in_place(min_pivot_ratio);
  } else {
    model_->gram().assemble(mu_values.data(), c_values.data());
    s = factor_->factorize(c_values.data(), min_pivot_ratio);
  }
  if (s == FactorStatus::Ok) {
    factor_valid_ = true;
    return Status::Ok;
  }
  return report_factor_failure(s);
}

Status Workspace::report_factor_failure(sparse::FactorStatus s) {
  using sparse::FactorStatus;
  switch (s) {
    case FactorStatus::Ok: return Status::Ok;
    case FactorStatus::NotPositiveDefinite:
      return fail(Status::DependentOneForms,
                  "%s%s: remove a redundant constraint, or change the step size if the motion only "
                  "passes through this configuration",
                  factor_->message(), row_note(factor_->failed_row()));
    case FactorStatus::NearlySingular:
      return fail(Status::NearlyDependentOneForms,
                  "%s%s: reduce the step size to pass this near-singular configuration (a jackknifing "
                  "train), or lower min_pivot_ratio if it is meant",
                  factor_->message(), row_note(factor_->failed_row()));
    case FactorStatus::NonFinite:
      return report_non_finite_one_forms();
    default:
      return fail(Status::LinearSolverFailure, "%s (%s): free memory or use a smaller model", factor_->message(),
                  sparse::to_string(s));
  }
}

Status Workspace::factorize_at(ConstVecRef q, double min_pivot_ratio) {
  const Status status = evaluate_one_forms(q);
  if (status != Status::Ok || factor_valid_) return status;
  return factorize(min_pivot_ratio);
}

Status Workspace::factorize_serial_at(ConstVecRef q, double min_pivot_ratio) {
  const Status status = evaluate_one_forms(q);
  if (status != Status::Ok || (factor_valid_ && !parted_)) return status;
  return factorize(min_pivot_ratio);
}

Status Workspace::solve(const double* b, double* x) {
  if (!factor_) return Status::Ok;
  if (parted_) {
    detail::solve_parted(*model_, *this, b, x);
    return Status::Ok;
  }
  if (factor_->solve(b, x) != sparse::FactorStatus::Ok)
    return fail(Status::LinearSolverFailure, "%s", factor_->message());
  return Status::Ok;
}

}  // namespace nonholo
