#pragma once
// FNV-1a of a text: equal texts give equal hashes on every rank and build (std::hash may differ
// by build). The MPI ranks' agreement on their command hashes it, and the command carries a scene
// file's bytes as their hash.
#include <cstdint>
#include <string>

namespace nonholo::scenarios {

inline std::uint64_t fnv1a(const std::string& text) {
  std::uint64_t h = 0xcbf29ce484222325ull;
  for (unsigned char c : text) h = (h ^ c) * 0x100000001b3ull;
  return h;
}

}  // namespace nonholo::scenarios
