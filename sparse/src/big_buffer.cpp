// Transparent huge pages for large buffers (big_buffer.hpp): madvise on the whole huge pages inside one.
#include <nonholo/sparse/big_buffer.hpp>

#include <algorithm>
#include <cstdint>
#include <cstring>

#if defined(__linux__)
#include <sys/mman.h>
#endif
#if defined(__GLIBC__)
#include <malloc.h>
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

void release_free_memory() {
// Sanitizers bring their own allocator: glibc's arenas are not in use (malloc_trim would crash).
#if defined(__GLIBC__) && !defined(__SANITIZE_ADDRESS__) && !defined(__SANITIZE_THREAD__)
  (void)malloc_trim(0);
#endif
}

void zero_bytes(void* data, std::size_t bytes) {
#if defined(__linux__) && defined(MADV_DONTNEED)
  // Below 64 kB a memset is cheaper than the system calls.
  constexpr std::size_t kPage = 4096, kSmall = std::size_t{64} << 10, kWindow = 4096;
  if (bytes >= kSmall && data != nullptr) {
    const std::uintptr_t start = reinterpret_cast<std::uintptr_t>(data);
    const std::uintptr_t begin = (start + kPage - 1) & ~(kPage - 1), end = (start + bytes) & ~(kPage - 1);
    // Only whole pages inside the buffer: the allocator's own words around it are not touched.
    // Resident pages (memory the allocator hands out again) are written: handing them back
    // would cost a fault each, in 4 kB pages where the page tables stay. The others are given
    // back (a page swapped out holds data): private anonymous memory, what malloc returns,
    // reads as zeros after MADV_DONTNEED, and untouched pages stay free until written.
    unsigned char resident[kWindow];
    bool ok = end > begin;
    for (std::uintptr_t at = begin; ok && at < end;) {
      const std::size_t pages = std::min<std::size_t>(kWindow, (end - at) / kPage);
      ok = mincore(reinterpret_cast<void*>(at), pages * kPage, resident) == 0;
      for (std::size_t k = 0; ok && k < pages;) {
        const bool in = resident[k] & 1;
        std::size_t run = k;
        while (run < pages && static_cast<bool>(resident[run] & 1) == in) ++run;
        void* first = reinterpret_cast<void*>(at + k * kPage);
        if (in)
          std::memset(first, 0, (run - k) * kPage);
        else
          ok = madvise(first, (run - k) * kPage, MADV_DONTNEED) == 0;
        k = run;
      }
      at += pages * kPage;
    }
    if (ok) {
      std::memset(data, 0, begin - start);
      std::memset(reinterpret_cast<void*>(end), 0, start + bytes - end);
      return;
    }
  }
#endif
  if (bytes > 0) std::memset(data, 0, bytes);
}

}  // namespace nonholo::sparse
