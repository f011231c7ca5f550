#include <nonholo/sparse/block_diagonal.hpp>

#include <Eigen/Cholesky>

namespace nonholo::sparse {

void BlockDiagonal::add_block(const Eigen::Ref<const Eigen::MatrixXd>& block) {
  const int k = static_cast<int>(block.rows());
  offsets_.push_back(size_);
  sizes_.push_back(k);
  starts_.push_back(static_cast<int>(values_.size()));
  for (int i = 0; i < k; ++i) {
    owner_.push_back(num_blocks() - 1);
    diag_.push_back(block(i, i));
    for (int j = 0; j < k; ++j) {
      values_.push_back(block(i, j));
      if (i != j && block(i, j) != 0.0) diagonal_ = false;
    }
  }
  size_ += k;
}

double BlockDiagonal::entry(int i, int j) const {
  const int b = owner_[i];
  if (owner_[j] != b) return 0.0;
  const int o = offsets_[b];
  return block_data(b)[(i - o) * sizes_[b] + (j - o)];
}

void BlockDiagonal::multiply(const double* x, double* y) const {
  if (diagonal_) {
    for (int i = 0; i < size_; ++i) y[i] = diag_[i] * x[i];
    return;
  }
  for (int b = 0; b < num_blocks(); ++b) {
    const int o = offsets_[b], k = sizes_[b];
    const double* a = block_data(b);
    for (int i = 0; i < k; ++i) {
      double s = 0.0;
      for (int j = 0; j < k; ++j) s += a[i * k + j] * x[o + j];
      y[o + i] = s;
    }
  }
}

BlockDiagonal BlockDiagonal::inverse() const {
  BlockDiagonal inv;
  for (int b = 0; b < num_blocks(); ++b) {
    const int k = sizes_[b];
    Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>> a(
        block_data(b), k, k);
    Eigen::MatrixXd ainv;
    if (diagonal_) {
      // Exact reciprocals: a diagonal metric should cost no round-off.
      ainv = a.diagonal().cwiseInverse().asDiagonal();
    } else {
      ainv = Eigen::LLT<Eigen::MatrixXd>(a).solve(Eigen::MatrixXd::Identity(k, k));
      // Symmetrise: round-off must not make W^T differ from W (C relies on it).
      ainv = (0.5 * (ainv + ainv.transpose())).eval();
    }
    inv.add_block(ainv);
  }
  return inv;
}

}  // namespace nonholo::sparse
