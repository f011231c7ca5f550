#pragma once
/// @file
/// LDL^T of a symmetric positive definite C whose natural order is banded (a chain ordered
/// body by body: half-bandwidth kd = 4), in band storage, without CHOLMOD (docs/design.md §7).
/// Row r of the band holds C(r, r-kd .. r) before factorisation and L(r, r-kd .. r-1), 1/D(r)
/// after (a multiplication in the solves instead of a division), so that a caller can also fill and eliminate it one row at a time while it streams
/// over the bodies (the fused chain step, core/src/step/chain/chain_sweep.cpp): eliminate_row() then
/// forward_row() per row, back_substitute() at the end. No allocation after construction.
#include <nonholo/sparse/big_buffer.hpp>
#include <nonholo/sparse/factorization.hpp>

#include <limits>
#include <vector>

namespace nonholo::sparse {

/// Half-bandwidth of the pattern in its natural order: max over entries (i, j) of i - j.
int half_bandwidth(const SymmetricPattern& pattern);
/// Auto's test for the banded path: the band, (kd + 1) rows wide, stores at most 4 times the
/// lower triangle's entries (so a few long-reaching rows do not make it wasteful) and
/// kd <= kBandedMaxBandwidth.
///@{
inline constexpr int kBandedMaxBandwidth = 32;
bool band_is_compact(const SymmetricPattern& pattern);
///@}

/// What the pivot tests of a row-by-row factorisation found: the smallest ratio pivot /
/// diagonal and its row, or the first row whose test failed. One per thread when threads
/// eliminate disjoint rows of one band (a partitioned chain step), merged in a fixed order.
struct PivotLog {
  double min_ratio = std::numeric_limits<double>::infinity();  ///< the smallest pivot / diagonal so far
  int min_row = -1;  ///< its row
  int bad_row = -1;  ///< the first row whose pivot test failed (-1: none)
  /// That row's pivot and diagonal.
  ///@{
  double bad_pivot = 0.0, bad_diagonal = 0.0;
  ///@}
  /// The pivot test of row r: the ratio d / diagonal is tested by products (a division is on
  /// no critical path but the reciprocal's) and divided out only at a new minimum. On success
  /// `slot` (the band's diagonal) gets 1 / d.
  bool accept(int r, double* slot, double d, double diagonal, double min_pivot_ratio) {
    if (!(diagonal > 0.0 && diagonal < kHuge && d >= min_pivot_ratio * diagonal && d > 0.0)) {
      bad_row = r;
      bad_pivot = d;
      bad_diagonal = diagonal;
      return false;
    }
    *slot = 1.0 / d;
    if (d < min_ratio * diagonal) {
      min_ratio = d / diagonal;
      min_row = r;
    }
    return true;
  }
  /// Takes in another log: the lower failed row, the smaller ratio (the first on a tie).
  void merge(const PivotLog& other) {
    if (other.bad_row >= 0 && (bad_row < 0 || other.bad_row < bad_row)) {
      bad_row = other.bad_row;
      bad_pivot = other.bad_pivot;
      bad_diagonal = other.bad_diagonal;
    }
    if (other.min_ratio < min_ratio) {
      min_ratio = other.min_ratio;
      min_row = other.min_row;
    }
  }
  static constexpr double kHuge = 1.7976931348623157e308;  ///< the largest finite double
};

/// The Banded backend (see banded_ldlt.hpp).
class BandedLdlt final : public Factorization {
 public:
  /// For C of this pattern (its half-bandwidth is kd).
  explicit BandedLdlt(const SymmetricPattern& pattern);
  /// A band of this size and half-bandwidth whose owner fills every row itself (row(),
  /// eliminate_row(): a chain of elements writes its rows in closed form), with no pattern:
  /// factorize() and factorize_in_place() then report InvalidInput.
  BandedLdlt(int size, int kd);
  /// The same with room for `spare_rows` more rows after its last (row(size()) onwards), for
  /// a band that another one lives in (the chain's tail partition: chain_partitions.hpp).
  BandedLdlt(int size, int kd, int spare_rows);
  /// A band in storage the caller owns (size * (kd + 1) doubles, which must outlive it), filled
  /// row by row as above; numeric_state()'s data is then nullptr (not saved in checkpoints).
  BandedLdlt(int size, int kd, double* storage);

  FactorStatus factorize(const double* c_values, double min_pivot_ratio) override;
  /// C's values written straight into the band (GramAssembler::assemble with slot_positions()):
  /// no copy of C, no c_values buffer (96 MB for a million-body chain).
  ///@{
  double* values_in_place() override { return data_; }
  const int* slot_positions() const override { return position_.data(); }
  FactorStatus factorize_in_place(double min_pivot_ratio) override;
  ///@}
  FactorStatus solve(const double* b, double* x) override;
  Backend backend() const override { return Backend::Banded; }  ///< Backend::Banded
  NumericState numeric_state() override {  ///< the band
    return owned_ ? NumericState{band_.data(), band_.size()} : NumericState{};
  }

  int bandwidth() const { return kd_; }  ///< kd, the half-bandwidth
  int stride() const { return kd_ + 1; }  ///< entries per row of the band
  /// Row r of the band: entry r - kd + t at [t], the diagonal at [kd].
  double* row(int r) { return data_ + static_cast<std::ptrdiff_t>(r) * (kd_ + 1); }
  /// Rows this band's own storage holds after its last (the spare rows, from row(size())).
  int spare_rows() const { return spare_rows_; }

  // --- row by row (fused steps) ---------------------------------------------------------
  /// Starts a factorisation whose rows the caller fills into row(r) (every band entry of the
  /// row, zeros included) and eliminates in order 0, 1, ..., size()-1.
  void begin_rows();
  /// Eliminates row r (rows before it already eliminated). Returns false when the pivot test
  /// fails; finish_rows() then reports why, as factorize() would. KD >= 0 fixes the bandwidth
  /// at compile time (it must equal bandwidth()): the loops unroll.
  template <int KD = -1>
  bool eliminate_row(int r, double min_pivot_ratio) {
    return eliminate_row<KD>(r, min_pivot_ratio, log_);
  }
  /// The same, its pivot test recorded in `log` (a thread's own: merge_pivots() takes it in).
  template <int KD = -1>
  bool eliminate_row(int r, double min_pivot_ratio, PivotLog& log) {
    const int kd = KD >= 0 ? KD : kd_;
    double* a = row(r);
    // First valid band column of row r: 0 past the first kd rows (then, with KD fixed, every
    // loop below has constant bounds and unrolls).
    const int lo = KD >= 0 && r >= KD ? 0 : (r - kd < 0 ? kd - r : 0);
    const double diagonal = a[kd];
    double d = diagonal;
    double work[KD > 0 ? KD : kBandedMaxBandwidth];  // C(r, s) - ..., i.e. L(r, s) D(s)
    for (int t = lo; t < kd; ++t) {
      const double* l = row(r - kd + t);
      double w = a[t];
      for (int u = lo; u < t; ++u) w -= work[u] * l[kd - (t - u)];
      work[t] = w;
      const double lrs = w * l[kd];  // the band's diagonal holds 1 / D
      a[t] = lrs;
      d -= w * lrs;
    }
    return log.accept(r, a + kd, d, diagonal, min_pivot_ratio);
  }
  /// y_r = (b_r - sum_s L(r, s) y_s) for s < r: the forward substitution of row r, in place.
  template <int KD = -1>
  void forward_row(int r, double* y) {
    const int kd = KD >= 0 ? KD : kd_;
    const double* a = row(r);
    const int lo = KD >= 0 && r >= KD ? 0 : (r - kd < 0 ? kd - r : 0);
    // Two partial sums: half the latency of one chain of kd subtractions.
    double v0 = y[r], v1 = 0.0;
    int t = lo;
    for (; t + 1 < kd; t += 2) {
      v0 -= a[t] * y[r - kd + t];
      v1 += a[t + 1] * y[r - kd + t + 1];
    }
    if (t < kd) v0 -= a[t] * y[r - kd + t];
    y[r] = v0 - v1;
  }
  /// x_r = y_r / D_r - sum_{s > r} L(s, r) x_s for one row, rows after r already done.
  template <int KD = -1>
  void backward_row(int r, double* x) {
    const int kd = KD >= 0 ? KD : kd_;
    const int m = size();
    double v0 = x[r] * row(r)[kd], v1 = 0.0;
    const int hi = KD >= 0 && r + KD < m ? KD : (r + kd < m ? kd : m - 1 - r);
    int k = 1;
    for (; k + 1 <= hi; k += 2) {
      v0 -= row(r + k)[kd - k] * x[r + k];
      v1 += row(r + k + 1)[kd - k - 1] * x[r + k + 1];
    }
    if (k <= hi) v0 -= row(r + k)[kd - k] * x[r + k];
    x[r] = v0 - v1;
  }
  /// The same three steps for a row whose band entries before column LO are structurally zero
  /// (and stay so: an LDL^T row fills only after its first nonzero), or whose column has no
  /// entry below row r + HI, with KD fixed and r away from the ends (r >= KD; r + HI < size()):
  /// constant bounds, no work on the zeros. The common chain's rows (chain_sweep.cpp) have
  /// LO = 2, 1, 0 and HI = 2, 4, 3.
  ///@{
  template <int KD, int LO>
  bool eliminate_interior_row(int r, double min_pivot_ratio) {
    double work[KD];
    return eliminate_interior_row<KD, LO>(r, min_pivot_ratio, log_, work);
  }
  /// ... with its own log, leaving L(r, s) D(s) of the columns s = r - KD + t (t >= LO) in
  /// work[t]: what a border row eliminated beside it needs (chain_partitions.cpp).
  template <int KD, int LO>
  bool eliminate_interior_row(int r, double min_pivot_ratio, PivotLog& log, double (&work)[KD]) {
    double* a = row(r);
    const double diagonal = a[KD];
    double d = diagonal;
    for (int t = LO; t < KD; ++t) {
      const double* l = row(r - KD + t);
      double w = a[t];
      for (int u = LO; u < t; ++u) w -= work[u] * l[KD - (t - u)];
      work[t] = w;
      const double lrs = w * l[KD];
      a[t] = lrs;
      d -= w * lrs;
    }
    return log.accept(r, a + KD, d, diagonal, min_pivot_ratio);
  }
  template <int KD, int LO>
  void forward_interior_row(int r, double* y) {
    const double* a = row(r);
    double v0 = y[r], v1 = 0.0;
    for (int t = LO; t < KD; ++t) (((t - LO) & 1) ? v1 : v0) -= a[t] * y[r - KD + t];
    y[r] = v0 + v1;
  }
  template <int KD, int HI>
  void backward_interior_row(int r, double* x) {
    double v0 = x[r] * row(r)[KD], v1 = 0.0;
    for (int k = 1; k <= HI; ++k) ((k & 1) ? v0 : v1) -= row(r + k)[KD - k] * x[r + k];
    x[r] = v0 + v1;
  }
  ///@}

  /// After eliminate_row for every row (or the first failing one): the status and message
  /// factorize() would give, and min_pivot_ratio()/min_pivot_row() set.
  FactorStatus finish_rows(double min_pivot_ratio);
  /// Takes a thread's PivotLog into the factorisation's (before finish_rows()).
  void merge_pivots(const PivotLog& log) { log_.merge(log); }

 private:
  template <int KD>
  void solve_fixed(double* x);
  template <int KD>
  void eliminate_fixed(double min_pivot_ratio);
  void eliminate_all(double min_pivot_ratio);
  FactorStatus no_pattern();
  int kd_;
  bool has_pattern_ = true;
  BigVector<double> band_;  // empty for a band in the caller's storage; zeros from the kernel
  double* data_ = nullptr;     // band_.data(), or the caller's storage
  int spare_rows_ = 0;
  bool owned_ = true;
  std::vector<int> position_;  // slot of C's pattern -> index in band_
  std::vector<int> outside_;   // band entries outside the pattern (zeroed before each factorisation)
  std::vector<double> work_;   // kd entries: row r times D, the elimination's running row
  PivotLog log_;  // the row-by-row factorisation's pivot tests (begin_rows() clears it)
};

}  // namespace nonholo::sparse
