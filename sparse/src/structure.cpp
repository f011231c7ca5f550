// Structural facts about C's pattern (structure.hpp): its validation, its diagonal blocks (union-find over
// its entries) and the envelope of its natural order.
#include <nonholo/sparse/structure.hpp>

#include <algorithm>
#include <numeric>
#include <stdexcept>
#include <string>

namespace nonholo::sparse {

int DiagonalBlocks::max_size() const {
  int largest = 0;
  for (int b = 0; b < count(); ++b) largest = std::max(largest, size(b));
  return largest;
}

void check_pattern(const SymmetricPattern& pattern) {
  const int m = pattern.size, nnz = pattern.nnz();
  const auto fail = [](const std::string& what) {
    throw std::invalid_argument("symmetric pattern: " + what);
  };
  const auto column = [](int j) { return "column " + std::to_string(j); };
  if (m < 0) fail("size " + std::to_string(m) + " is negative");
  if (pattern.col_ptr.size() != static_cast<std::size_t>(m) + 1 || pattern.col_ptr[0] != 0 ||
      pattern.col_ptr[m] != nnz)
    fail("col_ptr must hold size + 1 = " + std::to_string(m + 1) + " offsets from 0 to nnz = " +
         std::to_string(nnz));
  for (int j = 0; j < m; ++j) {
    const int begin = pattern.col_ptr[j], end = pattern.col_ptr[j + 1];
    if (begin >= end || end > nnz || pattern.row_idx[begin] != j)
      fail(column(j) + " is empty or does not start with its diagonal (row " +
           std::to_string(j) + ")");
    for (int s = begin + 1; s < end; ++s) {
      const int row = pattern.row_idx[s];
      if (row >= m)
        fail(column(j) + ": row " + std::to_string(row) + " is out of range (size " +
             std::to_string(m) + ", rows 0 to " + std::to_string(m - 1) + ")");
      if (row <= pattern.row_idx[s - 1])
        fail(column(j) + ": rows must increase, row " + std::to_string(row) + " follows " +
             std::to_string(pattern.row_idx[s - 1]));
    }
  }
}

DiagonalBlocks find_diagonal_blocks(const SymmetricPattern& pattern) {
  check_pattern(pattern);
  const int m = pattern.size;
  // Union-find over the off-diagonal entries; the root of a set is its smallest row.
  std::vector<int> parent(m);
  std::iota(parent.begin(), parent.end(), 0);
  auto root = [&](int i) {
    while (parent[i] != i) i = parent[i] = parent[parent[i]];
    return i;
  };
  for (int j = 0; j < m; ++j)
    for (int s = pattern.col_ptr[j]; s < pattern.col_ptr[j + 1]; ++s) {
      const int a = root(pattern.row_idx[s]), b = root(j);
      if (a != b) parent[std::max(a, b)] = std::min(a, b);
    }
  // Number the blocks by their smallest row, then bucket the rows (ascending) into them.
  std::vector<int> block(m, -1), counts;
  for (int i = 0; i < m; ++i) {
    const int r = root(i);
    if (r == i) {
      block[i] = static_cast<int>(counts.size());
      counts.push_back(0);
    }
    ++counts[block[r]];
    block[i] = block[r];
  }
  DiagonalBlocks result;
  result.block_ptr.resize(counts.size() + 1);
  result.block_ptr[0] = 0;
  for (std::size_t b = 0; b < counts.size(); ++b) result.block_ptr[b + 1] = result.block_ptr[b] + counts[b];
  result.rows.resize(m);
  std::vector<int> next(result.block_ptr.begin(), result.block_ptr.end() - 1);
  for (int i = 0; i < m; ++i) result.rows[next[block[i]]++] = i;
  return result;
}

long long natural_envelope(const SymmetricPattern& pattern) {
  check_pattern(pattern);
  const int m = pattern.size;
  std::vector<int> first(m);
  std::iota(first.begin(), first.end(), 0);
  // Column j touches rows row_idx[s] >= j: row i's first column is the smallest such j.
  for (int j = m - 1; j >= 0; --j)
    for (int s = pattern.col_ptr[j]; s < pattern.col_ptr[j + 1]; ++s) first[pattern.row_idx[s]] = j;
  long long envelope = 0;
  for (int i = 0; i < m; ++i) envelope += i - first[i] + 1;
  return envelope;
}

}  // namespace nonholo::sparse
