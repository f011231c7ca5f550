// The block-diagonal backend (block_llt.hpp): a dense in-place Cholesky of each connected block of C, and a
// division per row when every block has one row.
#include "block_llt.hpp"

#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

namespace nonholo::sparse {
namespace {

class BlockLLT final : public Factorization {
 public:
  BlockLLT(const SymmetricPattern& pattern, const DiagonalBlocks& blocks)
      : Factorization(pattern.size), blocks_(blocks), all_scalar_(blocks.max_size() <= 1) {
    const int m = pattern.size;
    // Block b stores its k x k lower triangle column-major at start_[b]; position_[slot] is
    // where slot `slot` of C lands (entries of a block outside the pattern stay zero).
    std::vector<int> block_of(m), local(m);
    start_.resize(blocks.count() + 1);
    start_[0] = 0;
    for (int b = 0; b < blocks.count(); ++b) {
      const int k = blocks.size(b);
      for (int t = 0; t < k; ++t) {
        block_of[blocks.rows[blocks.block_ptr[b] + t]] = b;
        local[blocks.rows[blocks.block_ptr[b] + t]] = t;
      }
      start_[b + 1] = start_[b] + k * k;
    }
    values_.assign(start_.back(), 0.0);
    position_.resize(pattern.nnz());
    for (int j = 0; j < m; ++j)
      for (int s = pattern.col_ptr[j]; s < pattern.col_ptr[j + 1]; ++s) {
        const int i = pattern.row_idx[s], b = block_of[j];
        const int k = blocks.size(b);
        position_[s] = start_[b] + local[i] + k * local[j];  // i >= j, both in block b
      }
    diag_slot_.resize(m);
    for (int at = 0; at < m; ++at) diag_slot_[at] = pattern.diagonal_slot(blocks.rows[at]);
    pivot_.resize(m);
    diag_.resize(m);
    work_.resize(m);
  }

  FactorStatus factorize(const double* c, double min_pivot_ratio) override {
    const int m = size();
    if (all_scalar_) {
      // C is diagonal: the pattern's slot j is C(j, j), its own pivot.
      for (int j = 0; j < m; ++j) {
        pivot_[j] = diag_[j] = c[j];
        values_[j] = 1.0 / c[j];
      }
      return check_pivots(pivot_.data(), diag_.data(), blocks_.rows.data(), min_pivot_ratio);
    }
    for (std::size_t s = 0; s < position_.size(); ++s) values_[position_[s]] = c[s];
    int at = 0;  // position in factor order (block rows concatenated)
    for (int b = 0; b < blocks_.count(); ++b) {
      const int k = blocks_.size(b);
      double* l = values_.data() + start_[b];
      // Right-looking Cholesky in place; pivots L_jj^2 are kept for the pivot check, and a
      // breakdown leaves the remaining diagonal entries as they are.
      bool broken = false;
      for (int j = 0; j < k; ++j, ++at) {
        diag_[at] = c[diag_slot_[at]];
        const double d = l[j + k * j];
        pivot_[at] = broken ? diag_[at] : d;  // rows after a breakdown are not reached
        if (broken || !(d > 0.0)) {
          broken = true;
          continue;
        }
        const double root = std::sqrt(d);
        l[j + k * j] = root;
        for (int i = j + 1; i < k; ++i) l[i + k * j] /= root;
        for (int jj = j + 1; jj < k; ++jj)
          for (int i = jj; i < k; ++i) l[i + k * jj] -= l[i + k * j] * l[jj + k * j];
      }
    }
    return check_pivots(pivot_.data(), diag_.data(), blocks_.rows.data(), min_pivot_ratio);
  }

  FactorStatus solve(const double* b, double* x) override {
    const int m = size();
    if (all_scalar_) {
      for (int j = 0; j < m; ++j) x[j] = b[j] * values_[j];
      return FactorStatus::Ok;
    }
    for (int blk = 0; blk < blocks_.count(); ++blk) {
      const int k = blocks_.size(blk);
      const int* rows = blocks_.rows.data() + blocks_.block_ptr[blk];
      const double* l = values_.data() + start_[blk];
      double* y = work_.data();
      for (int i = 0; i < k; ++i) {  // L y = b
        double s = b[rows[i]];
        for (int p = 0; p < i; ++p) s -= l[i + k * p] * y[p];
        y[i] = s / l[i + k * i];
      }
      for (int i = k - 1; i >= 0; --i) {  // L^T x = y
        double s = y[i];
        for (int p = i + 1; p < k; ++p) s -= l[p + k * i] * y[p];
        y[i] = s / l[i + k * i];
      }
      for (int i = 0; i < k; ++i) x[rows[i]] = y[i];
    }
    return FactorStatus::Ok;
  }

  Backend backend() const override { return Backend::BlockDiagonal; }

 private:
  DiagonalBlocks blocks_;
  bool all_scalar_;
  std::vector<int> start_, position_, diag_slot_;
  std::vector<double> values_, pivot_, diag_, work_;
};

}  // namespace

std::unique_ptr<Factorization> make_block_llt(const SymmetricPattern& pattern) {
  const DiagonalBlocks blocks = find_diagonal_blocks(pattern);
  if (blocks.max_size() > kMaxDiagonalBlock)
    throw std::invalid_argument(
        "backend block-diagonal: C has a coupled block of " + std::to_string(blocks.max_size()) +
        " one-forms (the largest it handles is " + std::to_string(kMaxDiagonalBlock) +
        "); use auto, cholmod-natural or cholmod-amd");
  return std::make_unique<BlockLLT>(pattern, blocks);
}

}  // namespace nonholo::sparse
