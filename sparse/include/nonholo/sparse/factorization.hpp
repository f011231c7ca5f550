#pragma once
/// @file
/// The one interface behind which C = mu M^-1 mu^T is factorised and solved. A
/// Factorization is built once for a fixed SymmetricPattern; factorize() and solve() then run
/// every step without allocating. Each object owns its own solver context (for CHOLMOD, one
/// cholmod_common), so use one per thread.
#include <nonholo/sparse/message.hpp>
#include <nonholo/sparse/patterns.hpp>

#include <cstddef>
#include <memory>
#include <string>
#include <vector>

namespace nonholo::sparse {

/// What a factorisation reports (to_string() gives its name).
enum class FactorStatus {
  Ok,                   ///< success
  NotPositiveDefinite,  ///< a pivot <= 0: the one-forms are dependent (C is singular)
  NearlySingular,       ///< a pivot below the tolerance: nearly dependent one-forms
  NonFinite,            ///< NaN or Inf in C or in a pivot
  OutOfMemory,          ///< CHOLMOD_OUT_OF_MEMORY
  TooLarge,             ///< CHOLMOD_TOO_LARGE: integer overflow in the factor's size
  InvalidInput,         ///< CHOLMOD_INVALID
  NotInstalled,         ///< CHOLMOD_NOT_INSTALLED
  GpuProblem,           ///< CHOLMOD_GPU_PROBLEM
  Failed,               ///< any other failure reported by the library
};
const char* to_string(FactorStatus status);  ///< "ok", "not positive definite", ...

/// @enum Backend
/// Which factorisation serves C (docs/design.md §3):
/// @var Backend::Auto
///   picks by structure; see resolve_backend.
/// @var Backend::BlockDiagonal
///   C splits into small independent blocks (every row touches one body):
///   a dense Cholesky per block, no sparse factorisation;
/// @var Backend::Dense
///   a small coupled C: dense Cholesky, fixed-size up to 4 rows;
/// @var Backend::Banded
///   LDL^T in band storage in the natural order (banded_ldlt.hpp): chains
///   ordered body by body; the fused chain step streams through it;
/// @var Backend::CholmodNatural
///   CHOLMOD simplicial LDL^T in the natural order (can be forced for banded C);
/// @var Backend::CholmodAmd
///   CHOLMOD simplicial LDL^T after an AMD ordering: general patterns.
enum class Backend { Auto, BlockDiagonal, Dense, Banded, CholmodNatural, CholmodAmd };
const char* to_string(Backend backend);  ///< "auto", "block-diagonal", ...
/// "auto", "block-diagonal", "dense", "banded", "cholmod-natural", "cholmod-amd"; throws
/// std::invalid_argument naming the valid choices.
Backend backend_from_string(const std::string& name);
/// Largest C handled by the dense path when the choice is Auto, and when it is forced.
///@{
inline constexpr int kDenseMaxSize = 8;
inline constexpr int kDenseForcedMaxSize = 2000;
///@}
/// Auto: BlockDiagonal if C has more than one block and every block has at most 8 rows;
/// otherwise Dense up to kDenseMaxSize rows; otherwise Banded if the natural order is banded
/// and its band compact (band_is_compact), else CholmodNatural if the natural envelope is at
/// most 2 nnz, else CholmodAmd. Any other request is returned.
Backend resolve_backend(Backend requested, const SymmetricPattern& pattern);

/// A factorisation of C for a fixed pattern (see factorization.hpp); make_factorization()
/// builds one for a Backend.
class Factorization {
 public:
  virtual ~Factorization() = default;
  Factorization(const Factorization&) = delete;
  Factorization& operator=(const Factorization&) = delete;

  /// Numeric factorisation of the matrix with these lower-triangle values (pattern order).
  /// Fails when a pivot, relative to its diagonal entry of C, is below min_pivot_ratio: for
  /// a Gram matrix that ratio is the squared sine of the angle between one row and the span
  /// of the rows eliminated before it, so it measures (near) dependence scale-free.
  virtual FactorStatus factorize(const double* c_values, double min_pivot_ratio) = 0;
  /// Optional zero-copy path. When values_in_place() is non-null, a caller may write slot s
  /// of C straight to values_in_place()[slot_positions()[s]] (GramAssembler::assemble does)
  /// and call factorize_in_place(), saving factorize()'s copy of every value.
  ///@{
  virtual double* values_in_place() { return nullptr; }
  virtual const int* slot_positions() const { return nullptr; }
  virtual FactorStatus factorize_in_place(double /*min_pivot_ratio*/) { return FactorStatus::Failed; }
  ///@}
  /// x = C^-1 b after a successful factorize(). b and x may alias.
  virtual FactorStatus solve(const double* b, double* x) = 0;

  virtual Backend backend() const = 0;  ///< which backend this is (never Auto)
  /// Where the numbers of a factorisation are (numeric_state()).
  struct NumericState {
    double* data = nullptr;  ///< the numbers, or nullptr
    std::size_t size = 0;    ///< how many
  };
  /// The numbers a successful factorisation left (checkpoints: restored, they make solve() give
  /// what it gave, bit for bit), when the backend exposes them; data nullptr otherwise (a
  /// checkpoint then factorises again).
  virtual NumericState numeric_state() { return {}; }
  int size() const { return size_; }  ///< the rows of C
  /// After factorize(): smallest pivot ratio and the row of C where it occurred.
  ///@{
  double min_pivot_ratio() const { return min_ratio_; }
  int min_pivot_row() const { return min_row_; }
  ///@}
  /// After a failed factorize(): the row of C at fault (-1 when the failure names none).
  int failed_row() const { return failed_row_; }
  /// Human-readable detail of the last failure ("" after success).
  const char* message() const { return message_.c_str(); }

 protected:
  explicit Factorization(int size) : size_(size) {}  ///< for C of `size` rows
  /// Shared pivot test. pivot[k] is the k-th pivot of the factor (D_kk, or L_kk^2) and
  /// diag[k] the matching diagonal entry of C; row[k] maps k back to a row of C.
  FactorStatus check_pivots(const double* pivot, const double* diag, const int* row,
                            double min_pivot_ratio);
  /// Records the message and returns status: `return fail(FactorStatus::..., "...", ...);`
  FactorStatus fail(FactorStatus status, const char* format, ...) __attribute__((format(printf, 3, 4))) {
    va_list args;
    va_start(args, format);
    message_.vset(format, args);
    va_end(args);
    return status;
  }
  void clear_message() { message_.clear(); }  ///< message() becomes ""
  void set_failed_row(int row) { failed_row_ = row; }  ///< what failed_row() reports
  /// For factorisations that test their pivots as they go (BandedLdlt).
  ///@{
  void set_pivot_summary(double min_ratio, int min_row) {
    min_ratio_ = min_ratio;
    min_row_ = min_row;
  }
  ///@}

 private:
  int size_;
  double min_ratio_ = 0.0;
  int min_row_ = -1;
  int failed_row_ = -1;
  Message message_;
};

/// Throws std::invalid_argument when the requested backend cannot serve this pattern
/// (block-diagonal for a coupled C, dense beyond kDenseForcedMaxSize rows).
std::unique_ptr<Factorization> make_factorization(Backend backend, const SymmetricPattern& pattern);

}  // namespace nonholo::sparse
