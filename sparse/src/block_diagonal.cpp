// BlockDiagonal (block_diagonal.hpp): blocks appended to its lean storage, entries, products and the inverse
// (exact reciprocals when diagonal, else a symmetrised Cholesky inverse of each block).
#include <nonholo/sparse/block_diagonal.hpp>

#include <Eigen/Cholesky>

namespace nonholo::sparse {

void BlockDiagonal::store_offsets() {
  const int k = uniform_;
  uniform_ = 0;
  offsets_.resize(static_cast<std::size_t>(blocks_) + 1);
  for (int b = 0; b <= blocks_; ++b) offsets_[b] = b * k;
  owner_.resize(static_cast<std::size_t>(size_));
  for (int i = 0; i < size_; ++i) owner_[i] = i / k;
  if (!diagonal_) {
    starts_.resize(static_cast<std::size_t>(blocks_));
    for (int b = 0; b < blocks_; ++b) starts_[b] = b * k * k;
  }
}

void BlockDiagonal::store_values() {
  diagonal_ = false;
  if (!uniform_) starts_.resize(static_cast<std::size_t>(blocks_));
  for (int b = 0; b < blocks_; ++b) {
    const int o = block_offset(b), k = block_size(b);
    if (!uniform_) starts_[b] = static_cast<int>(values_.size());
    for (int i = 0; i < k; ++i)
      for (int j = 0; j < k; ++j) values_.push_back(i == j ? diag_[o + i] : 0.0);
  }
}

void BlockDiagonal::add_block(const Eigen::Ref<const Eigen::MatrixXd>& block) {
  const int k = static_cast<int>(block.rows());
  if (blocks_ == 0) {
    if (k > 0)
      uniform_ = k;
    else
      offsets_.assign(1, 0);
  } else if (uniform_ && k != uniform_) {
    store_offsets();
  }
  bool block_diagonal = true;
  for (int i = 0; i < k && block_diagonal; ++i)
    for (int j = 0; j < k; ++j)
      if (i != j && block(i, j) != 0.0) {
        block_diagonal = false;
        break;
      }
  if (diagonal_ && !block_diagonal) store_values();
  if (!uniform_) {
    offsets_.push_back(size_ + k);  // offsets_ holds blocks_ + 1 entries
    owner_.insert(owner_.end(), static_cast<std::size_t>(k), blocks_);
    if (!diagonal_) starts_.push_back(static_cast<int>(values_.size()));
  }
  for (int i = 0; i < k; ++i) diag_.push_back(block(i, i));
  if (!diagonal_)
    for (int i = 0; i < k; ++i)
      for (int j = 0; j < k; ++j) values_.push_back(block(i, j));
  size_ += k;
  ++blocks_;
}

double BlockDiagonal::entry(int i, int j) const {
  if (i == j) return diag_[i];
  const int b = block_of(i);
  if (diagonal_ || block_of(j) != b) return 0.0;
  const int o = block_offset(b);
  return block_data(b)[(i - o) * block_size(b) + (j - o)];
}

void BlockDiagonal::multiply(const double* x, double* y) const { multiply(x, y, 0, size_); }

void BlockDiagonal::multiply(const double* x, double* y, int first, int last) const {
  if (first >= last) return;
  if (diagonal_) {
    for (int i = first; i < last; ++i) y[i] = diag_[i] * x[i];
    return;
  }
  for (int b = block_of(first), end = block_of(last - 1); b <= end; ++b) {
    const int o = block_offset(b), k = block_size(b);
    const double* a = block_data(b);
    for (int i = 0; i < k; ++i) {
      double s = 0.0;
      for (int j = 0; j < k; ++j) s += a[i * k + j] * x[o + j];
      y[o + i] = s;
    }
  }
}

BlockDiagonal BlockDiagonal::inverse() const {
  if (diagonal_) {
    // Exact reciprocals: a diagonal metric should cost no round-off. Same layout.
    BlockDiagonal inv = *this;
    for (double& d : inv.diag_) d = 1.0 / d;
    return inv;
  }
  BlockDiagonal inv;
  for (int b = 0; b < num_blocks(); ++b) {
    const int k = block_size(b);
    Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>> a(
        block_data(b), k, k);
    Eigen::MatrixXd ainv = Eigen::LLT<Eigen::MatrixXd>(a).solve(Eigen::MatrixXd::Identity(k, k));
    // Symmetrise: round-off must not make W^T differ from W (C relies on it).
    ainv = (0.5 * (ainv + ainv.transpose())).eval();
    inv.add_block(ainv);
  }
  return inv;
}

}  // namespace nonholo::sparse
