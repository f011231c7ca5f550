// Transparent huge pages for large buffers (big_buffer.hpp): madvise on the whole huge pages inside one.
#include <nonholo/sparse/big_buffer.hpp>

#include <cstdint>

#if defined(__linux__)
#include <sys/mman.h>
#endif

namespace nonholo::sparse {

void advise_huge_pages(void* data, std::size_t bytes) {
#if defined(__linux__) && defined(MADV_HUGEPAGE)
  if (bytes < kHugePageBytes || data == nullptr) return;
  const std::uintptr_t start = reinterpret_cast<std::uintptr_t>(data);
  const std::uintptr_t mask = ~(std::uintptr_t{kHugePageBytes} - 1);
  const std::uintptr_t begin = (start + kHugePageBytes - 1) & mask, end = (start + bytes) & mask;
  // The advice covers memory inside the buffer only; its failure (EINVAL where THP is not built
  // in) leaves ordinary pages.
  if (end > begin) (void)madvise(reinterpret_cast<void*>(begin), end - begin, MADV_HUGEPAGE);
#else
  (void)data;
  (void)bytes;
#endif
}

}  // namespace nonholo::sparse
