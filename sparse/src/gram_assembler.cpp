#include <nonholo/sparse/gram_assembler.hpp>

#include <algorithm>

namespace nonholo::sparse {

GramAssembler::GramAssembler(const RowPattern& a, const BlockDiagonal& w) {
  const int m = a.rows;
  pattern_.size = m;

  // Rows touching each block of W: the candidates for a nonzero C(r, c).
  std::vector<std::vector<int>> rows_of_block(w.num_blocks());
  for (int r = 0; r < m; ++r) {
    for (int k = a.row_ptr[r]; k < a.row_ptr[r + 1]; ++k) {
      auto& list = rows_of_block[w.block_of(a.col_idx[k])];
      if (list.empty() || list.back() != r) list.push_back(r);
    }
  }

  std::vector<int> candidates;
  for (int c = 0; c < m; ++c) {  // column c of the lower triangle, rows r >= c
    candidates.clear();
    for (int k = a.row_ptr[c]; k < a.row_ptr[c + 1]; ++k)
      for (int r : rows_of_block[w.block_of(a.col_idx[k])])
        if (r >= c) candidates.push_back(r);
    std::sort(candidates.begin(), candidates.end());
    candidates.erase(std::unique(candidates.begin(), candidates.end()), candidates.end());

    for (int r : candidates) {
      const std::size_t first = weight_.size();
      for (int kr = a.row_ptr[r]; kr < a.row_ptr[r + 1]; ++kr) {
        for (int kc = a.row_ptr[c]; kc < a.row_ptr[c + 1]; ++kc) {
          // On the diagonal the products (kr, kc) and (kc, kr) are equal: keep one, twice.
          if (r == c && kc < kr) continue;
          const double wt = w.entry(a.col_idx[kr], a.col_idx[kc]);
          if (wt == 0.0) continue;  // structural zero of the constant metric
          left_.push_back(kr);
          right_.push_back(kc);
          weight_.push_back((r == c && kc != kr) ? 2.0 * wt : wt);
        }
      }
      // The diagonal always has a slot (W is SPD, so it has products); an off-diagonal
      // pair whose every product has a structural zero weight is identically zero.
      if (weight_.size() == first && r != c) continue;
      pattern_.row_idx.push_back(r);
      slot_begin_.push_back(static_cast<int>(weight_.size()));
    }
    pattern_.col_ptr.push_back(pattern_.nnz());
  }
}

void GramAssembler::assemble(const double* a_values, double* c_values) const {
  const int slots = pattern_.nnz();
  for (int s = 0; s < slots; ++s) {
    double sum = 0.0;
    for (int t = slot_begin_[s]; t < slot_begin_[s + 1]; ++t)
      sum += weight_[t] * a_values[left_[t]] * a_values[right_[t]];
    c_values[s] = sum;
  }
}

}  // namespace nonholo::sparse
