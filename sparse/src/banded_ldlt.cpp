// The Banded backend (banded_ldlt.hpp): LDL^T of a banded C in band storage, factorised whole or row by row
// as the fused chain step streams it, and Auto's test of the band (half_bandwidth, band_is_compact).
#include <nonholo/sparse/banded_ldlt.hpp>

#include <nonholo/sparse/big_buffer.hpp>
#include <nonholo/sparse/structure.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace nonholo::sparse {

int half_bandwidth(const SymmetricPattern& pattern) {
  int kd = 0;
  for (int j = 0; j < pattern.size; ++j)
    for (int s = pattern.col_ptr[j]; s < pattern.col_ptr[j + 1]; ++s) kd = std::max(kd, pattern.row_idx[s] - j);
  return kd;
}

bool band_is_compact(const SymmetricPattern& pattern) {
  const int kd = half_bandwidth(pattern);
  return kd <= kBandedMaxBandwidth && static_cast<long long>(kd + 1) * pattern.size <= 4LL * pattern.nnz();
}

BandedLdlt::BandedLdlt(const SymmetricPattern& pattern)
    : Factorization(pattern.size), kd_(half_bandwidth(pattern)) {
  check_pattern(pattern);
  zero_buffer(band_, static_cast<std::size_t>(pattern.size) * (kd_ + 1));
  data_ = band_.data();
  position_.resize(pattern.nnz());
  for (int j = 0; j < pattern.size; ++j)
    for (int s = pattern.col_ptr[j]; s < pattern.col_ptr[j + 1]; ++s) {
      const int i = pattern.row_idx[s];
      position_[s] = i * (kd_ + 1) + kd_ - (i - j);
    }
  work_.assign(kd_ + 1, 0.0);
  std::vector<char> inside(band_.size(), 0);
  for (int at : position_) inside[static_cast<std::size_t>(at)] = 1;
  for (int r = 0; r < pattern.size; ++r)
    for (int t = std::max(0, kd_ - r); t < kd_; ++t)  // the diagonal (t = kd) is always in it
      if (!inside[static_cast<std::size_t>(r) * (kd_ + 1) + t]) outside_.push_back(r * (kd_ + 1) + t);
}

BandedLdlt::BandedLdlt(int size, int kd) : BandedLdlt(size, kd, 0) {}

BandedLdlt::BandedLdlt(int size, int kd, int spare_rows) : Factorization(size), kd_(kd), spare_rows_(spare_rows) {
  if (size < 0 || kd < 0 || kd > kBandedMaxBandwidth || spare_rows < 0)
    throw std::invalid_argument("BandedLdlt: size " + std::to_string(size) + " and half-bandwidth " +
                                std::to_string(kd) + " (at most " + std::to_string(kBandedMaxBandwidth) +
                                "), spare rows " + std::to_string(spare_rows));
  zero_buffer(band_, static_cast<std::size_t>(size + spare_rows) * (kd_ + 1));
  data_ = band_.data();
  work_.assign(kd_ + 1, 0.0);
  has_pattern_ = false;
}

BandedLdlt::BandedLdlt(int size, int kd, double* storage) : Factorization(size), kd_(kd), owned_(false) {
  if (size < 0 || kd < 0 || kd > kBandedMaxBandwidth || (!storage && size > 0))
    throw std::invalid_argument("BandedLdlt: size " + std::to_string(size) + " and half-bandwidth " +
                                std::to_string(kd) + " (at most " + std::to_string(kBandedMaxBandwidth) +
                                ") in the caller's storage (not null)");
  data_ = storage;
  work_.assign(kd_ + 1, 0.0);
  has_pattern_ = false;
}

FactorStatus BandedLdlt::factorize_in_place(double min_pivot_ratio) {
  if (!has_pattern_) return no_pattern();
  for (int at : outside_) band_[static_cast<std::size_t>(at)] = 0.0;  // L's fill from the last time
  begin_rows();
  eliminate_all(min_pivot_ratio);
  return finish_rows(min_pivot_ratio);
}

// Every row in order, the bandwidth fixed at compile time where it is small (the loops
// unroll: a 3-D ball chain's kd = 3 factorisation took 14 % of its general step with run-time
// bounds); stops at the first row whose pivot test fails.
template <int KD>
void BandedLdlt::eliminate_fixed(double min_pivot_ratio) {
  for (int r = 0; r < size(); ++r)
    if (!eliminate_row<KD>(r, min_pivot_ratio)) return;
}

void BandedLdlt::eliminate_all(double min_pivot_ratio) {
  switch (kd_) {
    case 0: return eliminate_fixed<0>(min_pivot_ratio);
    case 1: return eliminate_fixed<1>(min_pivot_ratio);
    case 2: return eliminate_fixed<2>(min_pivot_ratio);
    case 3: return eliminate_fixed<3>(min_pivot_ratio);
    case 4: return eliminate_fixed<4>(min_pivot_ratio);
    default: return eliminate_fixed<-1>(min_pivot_ratio);
  }
}

void BandedLdlt::begin_rows() {
  log_ = PivotLog{};
  if (size() == 0) log_.min_ratio = 1.0;
}

FactorStatus BandedLdlt::finish_rows(double min_pivot_ratio) {
  if (log_.bad_row < 0) {
    set_pivot_summary(log_.min_ratio, log_.min_row);
    set_failed_row(-1);
    clear_message();
    return FactorStatus::Ok;
  }
  const int r = log_.bad_row;
  const double pivot = log_.bad_pivot, diagonal = log_.bad_diagonal;
  const double ratio = pivot / diagonal;
  set_pivot_summary(ratio, r);
  set_failed_row(r);
  if (!std::isfinite(pivot) || !std::isfinite(diagonal))
    return fail(FactorStatus::NonFinite, "row %d of C: pivot %g, diagonal %g", r, pivot, diagonal);
  if (!(diagonal > 0.0))
    return fail(FactorStatus::NotPositiveDefinite, "row %d of C has diagonal %g: that one-form vanishes here", r,
                diagonal);
  if (!(ratio > 0.0))
    return fail(FactorStatus::NotPositiveDefinite,
                "pivot of row %d of C is %g times its diagonal: the one-forms are dependent", r, ratio);
  return fail(FactorStatus::NearlySingular,
              "pivot of row %d of C is %.3g times its diagonal (tolerance %.3g): the one-forms are nearly "
              "dependent",
              r, ratio, min_pivot_ratio);
}

FactorStatus BandedLdlt::no_pattern() {
  return fail(FactorStatus::InvalidInput, "this band was set up without a pattern: its owner fills its rows");
}

FactorStatus BandedLdlt::factorize(const double* c_values, double min_pivot_ratio) {
  if (!has_pattern_) return no_pattern();
  // Entries of the band outside the pattern (fill) must start at zero.
  std::fill(band_.begin(), band_.end(), 0.0);
  for (std::size_t s = 0; s < position_.size(); ++s) band_[position_[s]] = c_values[s];
  begin_rows();
  eliminate_all(min_pivot_ratio);
  return finish_rows(min_pivot_ratio);
}

// The substitutions with the bandwidth fixed at compile time, the rows away from the ends
// with constant loop bounds: the solve is a chain of dependent multiply-adds, and the loops
// with run-time bounds cost twice as much (measured in the holonomic chain step).
template <int KD>
void BandedLdlt::solve_fixed(double* x) {
  const int m = size();
  for (int r = 0; r < m && r < KD; ++r) forward_row<KD>(r, x);
  for (int r = KD; r < m; ++r) forward_interior_row<KD, 0>(r, x);
  for (int r = m - 1; r >= 0 && r + KD >= m; --r) backward_row<KD>(r, x);
  for (int r = m - KD - 1; r >= 0; --r) backward_interior_row<KD, KD>(r, x);
}

FactorStatus BandedLdlt::solve(const double* b, double* x) {
  const int m = size();
  if (x != b) std::copy(b, b + m, x);
  switch (kd_) {
    case 0: solve_fixed<0>(x); break;
    case 1: solve_fixed<1>(x); break;
    case 2: solve_fixed<2>(x); break;
    case 3: solve_fixed<3>(x); break;
    case 4: solve_fixed<4>(x); break;
    default:
      for (int r = 0; r < m; ++r) forward_row(r, x);
      for (int r = m - 1; r >= 0; --r) backward_row(r, x);
  }
  return FactorStatus::Ok;
}

}  // namespace nonholo::sparse
