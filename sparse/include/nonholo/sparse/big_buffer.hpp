#pragma once
/// @file
/// Large buffers sized once (a workspace's vectors, a band, a state) with transparent huge pages
/// where the system offers them: a 10^6-body chain's 2 GB took 543 000 page faults of 4 kB, each
/// 7-16 us on a virtual machine, a third of its set-up (docs/design.md, "Set-up"). Where the kernel
/// does not give huge pages (another system, THP "never") the buffers are ordinary ones.
#include <Eigen/Core>

#include <cstddef>
#include <memory>
#include <type_traits>
#include <utility>
#include <vector>

namespace nonholo::sparse {

/// Buffers of at least this many bytes ask for huge pages (one huge page: 2 MB on x86-64).
inline constexpr std::size_t kHugePageBytes = std::size_t{2} << 20;

/// Asks the kernel to back the whole huge pages inside [data, data + bytes) with transparent huge
/// pages when they are first touched (madvise MADV_HUGEPAGE on Linux; nothing elsewhere, or for
/// fewer than kHugePageBytes). Advice only: a refusal changes nothing but the speed.
void advise_huge_pages(void* data, std::size_t bytes);

/// Sets [data, data + bytes) to zero bytes. On Linux the whole pages inside a large buffer that
/// are not resident (fresh memory) are handed to the kernel (madvise MADV_DONTNEED), which gives
/// them zero-filled when they are first touched: the zeros cost no writes, and pages a run never
/// touches (a workspace's vectors that only some paths use) hold no memory. Resident pages, and
/// everything elsewhere or if the kernel refuses, are written with memset.
void zero_bytes(void* data, std::size_t bytes);

/// Hands the allocator's free memory back to the system (glibc: malloc_trim; nothing elsewhere).
/// Large buffers freed during set-up (a builder's tables, a scene's start) may sit inside the
/// heap, where glibc has raised its mmap threshold, and stay resident until trimmed: a
/// million-body chain's set-up leaves some 20 MB there.
void release_free_memory();

/// v holds n zeros; a new allocation is advised (advise_huge_pages) before it is first written.
template <class Derived>
void zero_buffer(Eigen::PlainObjectBase<Derived>& v, Eigen::Index n) {
  if (v.size() != n) {
    v.resize(n);
    advise_huge_pages(v.data(), static_cast<std::size_t>(n) * sizeof(typename Derived::Scalar));
  }
  static_assert(std::is_trivially_copyable_v<typename Derived::Scalar>, "zero bytes must be a zero value");
  zero_bytes(v.data(), static_cast<std::size_t>(n) * sizeof(typename Derived::Scalar));
}

/// An allocator whose construction without a value leaves the element default-initialised (for
/// a double: unwritten), so that resize() asks for memory without touching it (BigVector).
template <class T>
struct NoInitAllocator : std::allocator<T> {
  /// The same allocator for another element type (what std::allocator_traits asks for).
  template <class U>
  struct rebind {
    using other = NoInitAllocator<U>;  ///< NoInitAllocator of U
  };
  NoInitAllocator() = default;  ///< stateless
  /// From the allocator of another element type (stateless: nothing to copy).
  template <class U>
  NoInitAllocator(const NoInitAllocator<U>&) noexcept {}
  /// Without a value: default-initialised (a double is left unwritten).
  template <class U>
  void construct(U* p) noexcept(std::is_nothrow_default_constructible_v<U>) {
    ::new (static_cast<void*>(p)) U;
  }
  /// With values: constructed from them, as std::allocator does.
  template <class U, class... Args>
  void construct(U* p, Args&&... args) {
    ::new (static_cast<void*>(p)) U(std::forward<Args>(args)...);
  }
};
/// A vector for large buffers of trivial values: zero_buffer() gives it zeros without writing
/// fresh pages (a band the step writes before it reads it costs no set-up).
template <class T>
using BigVector = std::vector<T, NoInitAllocator<T>>;

/// v holds n zeros (zero_bytes: the kernel's, where the pages are fresh); a new allocation is
/// advised (advise_huge_pages) before it is first written.
template <class T>
void zero_buffer(BigVector<T>& v, std::size_t n) {
  static_assert(std::is_trivially_copyable_v<T>, "zero bytes must be a zero value");
  if (v.capacity() < n) {
    BigVector<T>().swap(v);
    v.reserve(n);
    advise_huge_pages(v.data(), n * sizeof(T));
  }
  v.resize(n);
  zero_bytes(v.data(), n * sizeof(T));
}

/// The same for a std::vector: n copies of value.
template <class T>
void fill_buffer(std::vector<T>& v, std::size_t n, const T& value) {
  if (v.capacity() < n) {
    std::vector<T>().swap(v);
    v.reserve(n);
    advise_huge_pages(v.data(), n * sizeof(T));
  }
  v.assign(n, value);
}

/// Room for n elements in v (std::vector::reserve), a new allocation advised before it is written.
template <class T>
void reserve_buffer(std::vector<T>& v, std::size_t n) {
  if (v.capacity() >= n) return;
  v.reserve(n);
  advise_huge_pages(v.data(), n * sizeof(T));
}

}  // namespace nonholo::sparse
