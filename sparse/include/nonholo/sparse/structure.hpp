#pragma once
/// @file
/// Structural facts about the pattern of C that decide how to factorise it (docs/design.md
/// §3, "model only what a scene needs"): whether it splits into small independent
/// blocks, and whether its natural order is already banded.
#include <nonholo/sparse/patterns.hpp>

#include <vector>

namespace nonholo::sparse {

/// Throws std::invalid_argument unless the pattern is what SymmetricPattern promises: col_ptr
/// of size + 1 non-decreasing offsets from 0 to nnz, each column starting at its diagonal, rows
/// strictly increasing and below size. Every function here and resolve_backend check it.
void check_pattern(const SymmetricPattern& pattern);

/// The connected components of C's graph: C is block-diagonal after grouping these rows.
/// Block b holds rows[block_ptr[b] .. block_ptr[b+1]), sorted; blocks are ordered by their
/// first row.
struct DiagonalBlocks {
  std::vector<int> block_ptr{0};  ///< count() + 1 offsets into rows
  std::vector<int> rows;  ///< the rows of each block
  int count() const { return static_cast<int>(block_ptr.size()) - 1; }  ///< number of blocks
  int size(int b) const { return block_ptr[b + 1] - block_ptr[b]; }  ///< rows of block b
  int max_size() const;  ///< rows of the largest block (0 when there is none)
};
/// The connected components of the pattern's graph (see DiagonalBlocks).
DiagonalBlocks find_diagonal_blocks(const SymmetricPattern& pattern);

/// Entries of the lower envelope in the natural order: sum over rows i of (i - first column
/// of row i) + 1. A Cholesky factor in the natural order fills at most this envelope, so
/// envelope <= 2 nnz(lower C) means the natural order is banded and needs no fill-reducing
/// permutation.
long long natural_envelope(const SymmetricPattern& pattern);

}  // namespace nonholo::sparse
