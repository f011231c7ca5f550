// What the backends share (factorization.hpp): the names of statuses and backends, Auto's choice of backend
// from C's structure, the pivot check every factorisation ends with, and make_factorization.
#include <nonholo/sparse/factorization.hpp>

#include <cmath>
#include <stdexcept>
#include <string>

#include <nonholo/sparse/banded_ldlt.hpp>
#include <nonholo/sparse/structure.hpp>

#include "block_llt.hpp"
#include "cholmod_ldlt.hpp"
#include "dense_llt.hpp"

namespace nonholo::sparse {

const char* to_string(FactorStatus status) {
  switch (status) {
    case FactorStatus::Ok: return "ok";
    case FactorStatus::NotPositiveDefinite: return "not positive definite";
    case FactorStatus::NearlySingular: return "nearly singular";
    case FactorStatus::NonFinite: return "non-finite values";
    case FactorStatus::OutOfMemory: return "out of memory";
    case FactorStatus::TooLarge: return "problem too large";
    case FactorStatus::InvalidInput: return "invalid input";
    case FactorStatus::NotInstalled: return "method not installed";
    case FactorStatus::GpuProblem: return "GPU problem";
    case FactorStatus::Failed: return "factorisation failed";
  }
  return "unknown";
}

const char* to_string(Backend backend) {
  switch (backend) {
    case Backend::Auto: return "auto";
    case Backend::BlockDiagonal: return "block-diagonal";
    case Backend::Dense: return "dense";
    case Backend::Banded: return "banded";
    case Backend::CholmodNatural: return "cholmod-natural";
    case Backend::CholmodAmd: return "cholmod-amd";
  }
  return "unknown";
}

Backend backend_from_string(const std::string& name) {
  for (Backend b : {Backend::Auto, Backend::BlockDiagonal, Backend::Dense, Backend::Banded,
                    Backend::CholmodNatural, Backend::CholmodAmd})
    if (name == to_string(b)) return b;
  throw std::invalid_argument("unknown backend '" + name +
                              "' (valid: auto, block-diagonal, dense, banded, cholmod-natural, cholmod-amd)");
}

Backend resolve_backend(Backend requested, const SymmetricPattern& pattern) {
  check_pattern(pattern);  // every backend indexes by it
  if (requested != Backend::Auto) return requested;
  const DiagonalBlocks blocks = find_diagonal_blocks(pattern);
  if (blocks.count() > 1 && blocks.max_size() <= kMaxDiagonalBlock) return Backend::BlockDiagonal;
  if (pattern.size <= kDenseMaxSize) return Backend::Dense;
  if (band_is_compact(pattern)) return Backend::Banded;
  if (natural_envelope(pattern) <= 2LL * pattern.nnz()) return Backend::CholmodNatural;
  return Backend::CholmodAmd;
}

FactorStatus Factorization::check_pivots(const double* pivot, const double* diag,
                                         const int* row, double min_pivot_ratio) {
  min_ratio_ = size_ == 0 ? 1.0 : INFINITY;
  min_row_ = -1;
  failed_row_ = -1;
  for (int k = 0; k < size_; ++k) {
    failed_row_ = row[k];
    if (!std::isfinite(pivot[k]) || !std::isfinite(diag[k]))
      return fail(FactorStatus::NonFinite, "row %d of C: pivot %g, diagonal %g", row[k],
                  pivot[k], diag[k]);
    if (!(diag[k] > 0.0))
      return fail(FactorStatus::NotPositiveDefinite,
                  "row %d of C has diagonal %g: that one-form vanishes here", row[k], diag[k]);
    const double ratio = pivot[k] / diag[k];
    if (ratio < min_ratio_) {
      min_ratio_ = ratio;
      min_row_ = row[k];
    }
  }
  failed_row_ = min_row_;
  if (!(min_ratio_ > 0.0))
    return fail(FactorStatus::NotPositiveDefinite,
                "pivot of row %d of C is %g times its diagonal: the one-forms are dependent",
                min_row_, min_ratio_);
  if (min_ratio_ < min_pivot_ratio)
    return fail(FactorStatus::NearlySingular,
                "pivot of row %d of C is %.3g times its diagonal (tolerance %.3g): the "
                "one-forms are nearly dependent",
                min_row_, min_ratio_, min_pivot_ratio);
  failed_row_ = -1;
  clear_message();
  return FactorStatus::Ok;
}

std::unique_ptr<Factorization> make_factorization(Backend backend, const SymmetricPattern& pattern) {
  switch (resolve_backend(backend, pattern)) {
    case Backend::BlockDiagonal: return make_block_llt(pattern);
    case Backend::Dense:
      if (pattern.size > kDenseForcedMaxSize)
        throw std::invalid_argument("backend dense: C has " + std::to_string(pattern.size) +
                                    " rows; the dense path stops at " +
                                    std::to_string(kDenseForcedMaxSize) + " (use auto)");
      return make_dense_llt(pattern);
    case Backend::Banded: return std::make_unique<BandedLdlt>(pattern);
    case Backend::CholmodNatural: return std::make_unique<CholmodLDLT>(pattern, CholmodOrdering::Natural);
    case Backend::CholmodAmd: return std::make_unique<CholmodLDLT>(pattern, CholmodOrdering::Amd);
    case Backend::Auto: break;
  }
  throw std::logic_error("make_factorization: unresolved backend");
}

}  // namespace nonholo::sparse
