#pragma once
// Rows that are dependent by their pattern alone: more one-form rows than the columns they
// touch (a scene with 10^4 copies of one knife edge). No values can make them independent, and
// C = mu M^-1 mu^T of such rows is dense (10^8 entries for 10^4 copies on one body), so the
// builder refuses them before C's pattern exists: a maximum matching of rows to columns
// (Hopcroft-Karp, O(nnz sqrt(rows)) time, O(rows + cols) memory).
#include <vector>

namespace nonholo::detail {

// An over-determined part of the pattern: `rows` touch only `columns`, and there are more rows
// than columns (both ascending). Empty when every row can be matched to a column of its own.
struct StructuralDeficiency {
  std::vector<int> rows, columns;
  bool empty() const { return rows.empty(); }
};

// Rows 0 .. rows-1, row r's columns col_idx[row_ptr[r] .. row_ptr[r+1]) in [0, cols).
StructuralDeficiency structural_deficiency(int rows, int cols, const std::vector<int>& row_ptr,
                                           const std::vector<int>& col_idx);

}  // namespace nonholo::detail
