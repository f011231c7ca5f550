#pragma once
// A symmetric block-diagonal matrix (the mass metric M and its inverse), one dense block
// per body. Blocks are stored row-major, back to back.
#include <Eigen/Core>
#include <vector>

namespace nonholo::sparse {

class BlockDiagonal {
 public:
  // Appends a square block; the caller has validated it.
  void add_block(const Eigen::Ref<const Eigen::MatrixXd>& block);

  int size() const { return size_; }
  int num_blocks() const { return static_cast<int>(offsets_.size()); }
  int block_offset(int b) const { return offsets_[b]; }
  int block_size(int b) const { return sizes_[b]; }
  // Row-major k x k entries of block b.
  const double* block_data(int b) const { return values_.data() + starts_[b]; }
  // Block owning coordinate i.
  int block_of(int i) const { return owner_[i]; }
  // Entry (i, j); zero when i and j lie in different blocks.
  double entry(int i, int j) const;
  // True when every block is diagonal: products then reduce to a scaled copy.
  bool is_diagonal() const { return diagonal_; }
  // The diagonal entries (size() of them); all of the matrix when is_diagonal().
  const double* diagonal() const { return diag_.data(); }

  // y = B x (x and y must not alias).
  void multiply(const double* x, double* y) const;
  // The inverse, block by block (blocks must be SPD).
  BlockDiagonal inverse() const;

 private:
  int size_ = 0;
  bool diagonal_ = true;
  std::vector<int> offsets_, sizes_, starts_, owner_;
  std::vector<double> values_;
  std::vector<double> diag_;
};

}  // namespace nonholo::sparse
