#pragma once
// Everything a thread needs to integrate one Model: every buffer sized once here, and its
// own factorisation of C (for CHOLMOD, its own cholmod_common). One Workspace per thread;
// the Model must outlive it. The buffers are scratch owned by the integrators.
#include <nonholo/model.hpp>
#include <nonholo/sparse/factorization.hpp>
#include <nonholo/sparse/message.hpp>
#include <nonholo/status.hpp>

#include <memory>

namespace nonholo {

struct WorkspaceOptions {
  sparse::Backend backend = sparse::Backend::Auto;
};

class Workspace {
 public:
  explicit Workspace(const Model& model, const WorkspaceOptions& options = {});

  const Model& model() const { return *model_; }
  // The factorisation in use (see sparse::Backend); "none" for a model without one-forms.
  sparse::Backend backend() const;
  const char* backend_name() const;
  // Why the last failed call failed ("" if it did not).
  const char* message() const { return message_.c_str(); }

  // --- used by the integrators (nonholo/rattle.hpp, start.hpp, dynamics.hpp) --------------
  // Evaluates mu at q into mu_values unless they already hold mu(q) (mu is a pure function
  // of q, so the cache is keyed by the bits of q). NaN or Inf in mu is reported by the
  // factorize() that follows (NonFiniteOneForms, naming the row and column).
  Status evaluate_one_forms(ConstVecRef q);
  // Assembles C from mu_values and factorises it.
  Status factorize(double min_pivot_ratio);
  // Makes the factorisation hold C(q): nothing to do when it already does (the step that
  // arrived at q left it there), otherwise evaluate_one_forms(q) and factorize().
  Status factorize_at(ConstVecRef q, double min_pivot_ratio);
  // lambda = C^-1 rhs after factorize().
  Status solve(const double* rhs, double* lambda);
  // Records the message and returns status: `return ws.fail(Status::..., "...", ...);`
  Status fail(Status status, const char* format, ...) __attribute__((format(printf, 3, 4))) {
    va_list args;
    va_start(args, format);
    message_.vset(format, args);
    va_end(args);
    return status;
  }
  void clear_message() { message_.clear(); }

  // Scratch vectors of size n (coordinates) ...
  Vector q_next, p_half, p_hat, p_next, velocity, applied, force_next, scratch_n, scratch_n2;
  // ... of size nnz(mu), nnz(C) and m (one-form rows). c_values holds C only for the
  // factorisations without an in-place path (it is empty with CHOLMOD).
  Vector mu_values, c_values, rhs, lambda, scratch_m, scratch_nnz, scratch_nnz2;
  // ... and of size num_holonomic() (hitch gaps g(q)).
  Vector gap;
  // Position-level iterations taken by the last step in holonomic mode.
  int gap_iterations = 0;

 private:
  const Model* model_;
  std::unique_ptr<sparse::Factorization> factor_;
  Vector mu_q_;  // the q whose one-form values mu_values holds, when mu_valid_
  bool mu_valid_ = false;
  bool factor_valid_ = false;  // the factorisation holds C(mu_values)
  Status report_non_finite_one_forms();
  sparse::Message message_;
};

}  // namespace nonholo
