#pragma once
// Fixed sparsity patterns: the rows of the one-forms mu (CSR) and the lower triangle of
// the symmetric C = mu M^-1 mu^T (CSC). Patterns are built once; only values change.
#include <vector>

namespace nonholo::sparse {

// Compressed rows: row r holds columns col_idx[row_ptr[r] .. row_ptr[r+1]).
struct RowPattern {
  int rows = 0;
  int cols = 0;
  std::vector<int> row_ptr{0};
  std::vector<int> col_idx;
  int nnz() const { return static_cast<int>(col_idx.size()); }
};

// Lower triangle (row >= column) of a symmetric matrix, compressed by column, rows sorted
// within each column; the first entry of every column is its diagonal.
struct SymmetricPattern {
  int size = 0;
  std::vector<int> col_ptr{0};
  std::vector<int> row_idx;
  int nnz() const { return static_cast<int>(row_idx.size()); }
  int diagonal_slot(int j) const { return col_ptr[j]; }
};

}  // namespace nonholo::sparse
