#pragma once
// C block-diagonal (every connected group of one-forms is small, e.g. every row touches one
// body): a dense Cholesky per block, no sparse factorisation. Blocks of one row, the common
// case of independent knife edges, reduce to a division.
#include <nonholo/sparse/factorization.hpp>
#include <nonholo/sparse/structure.hpp>

#include <memory>

namespace nonholo::sparse {

// Largest block accepted (the per-block factorisation is dense).
inline constexpr int kMaxDiagonalBlock = 8;

// Throws std::invalid_argument when a block of the pattern exceeds kMaxDiagonalBlock.
std::unique_ptr<Factorization> make_block_llt(const SymmetricPattern& pattern);

}  // namespace nonholo::sparse
