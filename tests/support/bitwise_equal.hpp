#pragma once
// Bit-for-bit equality of vectors: "left as it was" and "the same for any thread count" mean
// exactly equal, not close.
#include <nonholo/types.hpp>

#include <cstring>

namespace nonholo::testing {

// An empty Eigen vector's data() is null, and memcmp needs valid pointers even for 0 bytes.
inline bool bitwise_equal(const Vector& a, const Vector& b) {
  return a.size() == b.size() &&
         (a.size() == 0 || std::memcmp(a.data(), b.data(), sizeof(double) * a.size()) == 0);
}

}  // namespace nonholo::testing
