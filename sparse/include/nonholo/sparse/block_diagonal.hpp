#pragma once
/// @file
/// A symmetric block-diagonal matrix (the mass metric M and its inverse), one dense block
/// per body. Stored lean, for a million bodies: the diagonal always; the blocks' full entries
/// (row-major, back to back) only once some block is not diagonal; the blocks' offsets and the
/// owner of each coordinate only once the blocks differ in size (else they are computed).
#include <Eigen/Core>

#include <nonholo/sparse/big_buffer.hpp>
#include <vector>

namespace nonholo::sparse {

/// A symmetric block-diagonal matrix, built block by block (see block_diagonal.hpp).
class BlockDiagonal {
 public:
  /// Appends a square block; the caller has validated it.
  void add_block(const Eigen::Ref<const Eigen::MatrixXd>& block);
  /// Room for this many coordinates (no regrowth while a large model is added block by block).
  void reserve(int coordinates) { reserve_buffer(diag_, static_cast<std::size_t>(coordinates)); }

  int size() const { return size_; }  ///< rows (and columns)
  int num_blocks() const { return blocks_; }  ///< blocks added
  /// Block b's first row, and its number of rows.
  ///@{
  int block_offset(int b) const { return uniform_ ? b * uniform_ : offsets_[b]; }
  int block_size(int b) const { return uniform_ ? uniform_ : offsets_[b + 1] - offsets_[b]; }
  ///@}
  /// Row-major k x k entries of block b; only when !is_diagonal() (a diagonal matrix keeps
  /// its diagonal alone: use entry() or diagonal()).
  const double* block_data(int b) const { return values_.data() + (uniform_ ? b * uniform_ * uniform_ : starts_[b]); }
  /// Block owning coordinate i.
  int block_of(int i) const { return uniform_ ? i / uniform_ : owner_[i]; }
  /// Entry (i, j); zero when i and j lie in different blocks.
  double entry(int i, int j) const;
  /// True when every block is diagonal: products then reduce to a scaled copy.
  bool is_diagonal() const { return diagonal_; }
  /// The diagonal entries (size() of them); all of the matrix when is_diagonal().
  const double* diagonal() const { return diag_.data(); }

  /// y = B x (x and y must not alias).
  void multiply(const double* x, double* y) const;
  /// The same on the entries [first, last) only, which must start and end at block boundaries
  /// (block_offset); the other entries of y are not touched.
  void multiply(const double* x, double* y, int first, int last) const;
  /// The inverse, block by block (blocks must be SPD).
  BlockDiagonal inverse() const;

 private:
  void store_offsets();  // the blocks differ in size from now on
  void store_values();   // some block is not diagonal from now on

  int size_ = 0;
  int blocks_ = 0;
  int uniform_ = 0;  // the size every block has (> 0), or 0: offsets_ and owner_ are stored
  bool diagonal_ = true;
  std::vector<int> offsets_;  // num_blocks() + 1 first coordinates; only when !uniform_
  std::vector<int> owner_;    // block of each coordinate; only when !uniform_
  std::vector<int> starts_;   // first entry of each block in values_; only when !uniform_ && !diagonal_
  std::vector<double> values_;  // the blocks, row-major; only when !diagonal_
  std::vector<double> diag_;
};

}  // namespace nonholo::sparse
