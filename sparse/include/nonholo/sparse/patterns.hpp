#pragma once
/// @file
/// Fixed sparsity patterns: the rows of the one-forms mu (CSR) and the lower triangle of
/// the symmetric C = mu M^-1 mu^T (CSC). Patterns are built once; only values change.
#include <vector>

namespace nonholo::sparse {

/// Compressed rows: row r holds columns col_idx[row_ptr[r] .. row_ptr[r+1]).
struct RowPattern {
  int rows = 0;  ///< number of rows
  int cols = 0;  ///< number of columns
  std::vector<int> row_ptr{0};  ///< rows + 1 offsets into col_idx
  std::vector<int> col_idx;  ///< the columns of each row, in order
  int nnz() const { return static_cast<int>(col_idx.size()); }  ///< number of entries
};

/// Lower triangle (row >= column) of a symmetric matrix, compressed by column, rows sorted
/// within each column; the first entry of every column is its diagonal.
struct SymmetricPattern {
  int size = 0;  ///< rows (and columns)
  std::vector<int> col_ptr{0};  ///< size + 1 offsets into row_idx
  std::vector<int> row_idx;  ///< the rows of each column's entries, ascending
  int nnz() const { return static_cast<int>(row_idx.size()); }  ///< entries of the lower triangle
  int diagonal_slot(int j) const { return col_ptr[j]; }  ///< the slot of entry (j, j)
};

}  // namespace nonholo::sparse
