// The dense backend (dense_llt.hpp): Eigen's Cholesky of a small C, of fixed size for 1 to 4 rows, with the
// pivots recomputed from the factor so that a breakdown is located.
#include "dense_llt.hpp"

#include <Eigen/Cholesky>
#include <vector>

namespace nonholo::sparse {
namespace {

template <int N>
class DenseLLT final : public Factorization {
  using Matrix = Eigen::Matrix<double, N, N>;
  using Vector = Eigen::Matrix<double, N, 1>;

 public:
  explicit DenseLLT(const SymmetricPattern& pattern)
      : Factorization(pattern.size),
        c_(Matrix::Zero(pattern.size, pattern.size)),
        llt_(pattern.size),
        pivot_(pattern.size),
        diag_(pattern.size),
        rows_(pattern.size),
        index_(pattern.nnz()) {
    const int m = pattern.size;
    for (int j = 0; j < m; ++j) {
      rows_[j] = j;
      for (int s = pattern.col_ptr[j]; s < pattern.col_ptr[j + 1]; ++s)
        index_[s] = pattern.row_idx[s] + j * m;  // column-major, lower triangle
    }
  }

  FactorStatus factorize(const double* c_values, double min_pivot_ratio) override {
    const int m = size();
    for (std::size_t s = 0; s < index_.size(); ++s) c_.data()[index_[s]] = c_values[s];
    llt_.compute(c_);
    // Pivots L_jj^2 = C_jj - |L(j, 0:j)|^2, recomputed from the factor so that a breakdown
    // is located: Eigen stops at the first non-positive one and leaves later rows untouched.
    const auto& l = llt_.matrixLLT();
    for (int j = 0; j < m; ++j) {
      diag_[j] = c_(j, j);
      pivot_[j] = diag_[j] - l.row(j).head(j).squaredNorm();
      if (!(pivot_[j] > 0.0)) {
        for (int k = j + 1; k < m; ++k) pivot_[k] = diag_[k] = c_(k, k);
        break;
      }
    }
    return check_pivots(pivot_.data(), diag_.data(), rows_.data(), min_pivot_ratio);
  }

  FactorStatus solve(const double* b, double* x) override {
    Eigen::Map<Vector> xv(x, size());
    if (x != b) xv = Eigen::Map<const Vector>(b, size());
    llt_.solveInPlace(xv);
    return FactorStatus::Ok;
  }

  Backend backend() const override { return Backend::Dense; }

 private:
  Matrix c_;
  Eigen::LLT<Matrix, Eigen::Lower> llt_;
  Vector pivot_, diag_;
  std::vector<int> rows_;
  std::vector<int> index_;  // slot of the pattern -> position in c_
};

}  // namespace

std::unique_ptr<Factorization> make_dense_llt(const SymmetricPattern& pattern) {
  switch (pattern.size) {
    case 1: return std::make_unique<DenseLLT<1>>(pattern);
    case 2: return std::make_unique<DenseLLT<2>>(pattern);
    case 3: return std::make_unique<DenseLLT<3>>(pattern);
    case 4: return std::make_unique<DenseLLT<4>>(pattern);
    default: return std::make_unique<DenseLLT<Eigen::Dynamic>>(pattern);
  }
}

}  // namespace nonholo::sparse
