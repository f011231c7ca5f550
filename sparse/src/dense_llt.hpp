#pragma once
// Dense Cholesky of a small C: fixed-size (no heap at all) for sizes 1 to 4, and a dynamic
// matrix allocated once for larger sizes.
#include <nonholo/sparse/factorization.hpp>

#include <memory>

namespace nonholo::sparse {

std::unique_ptr<Factorization> make_dense_llt(const SymmetricPattern& pattern);

}  // namespace nonholo::sparse
