// The grid filter's large arrays, each starting at its own offset within a 4 KiB page.
//
// glibc serves blocks of 128 KiB and more (one float per cell of a 300 x 300 grid: 352 KiB) with
// mmap, so such arrays start at the same offset within a page. The filter's cell loops read and
// write ten and more of them at the same index: element i of every one then falls into the same
// set of the 8-way L1 data cache, and the loop misses at every cache line. A filter whose arrays
// came from mmap ran its cycle in 17.9 ms, the same filter with its arrays from the heap (other
// offsets: glibc raises its mmap threshold once a large block is freed) in 12.4 ms
// (bench_dynamic_grid, 1 thread; doc/benchmarks.md). StaggeredAllocator gives each array the next
// of 63 offsets, a cache line apart, whatever the allocator underneath does.
#pragma once

#include <atomic>
#include <cstddef>
#include <cstring>
#include <limits>
#include <new>
#include <vector>

namespace grid_vision_fusion
{
template <typename T>
class StaggeredAllocator
{
public:
  using value_type = T;

  StaggeredAllocator() noexcept = default;
  template <typename U>
  StaggeredAllocator(const StaggeredAllocator<U>& /*other*/) noexcept
  {
  }

  T* allocate(std::size_t n)
  {
    const std::size_t offset = nextOffset();
    if (n > (std::numeric_limits<std::size_t>::max() - offset) / sizeof(T))
    {
      throw std::bad_array_new_length();
    }
    char* base = static_cast<char*>(::operator new (n * sizeof(T) + offset, std::align_val_t{kLine}));
    char* data = base + offset;
    std::memcpy(data - sizeof offset, &offset, sizeof offset);  // in the padding, for deallocate
    return reinterpret_cast<T*>(data);
  }

  void deallocate(T* p, std::size_t /*n*/) noexcept
  {
    char* data = reinterpret_cast<char*>(p);
    std::size_t offset = 0;
    std::memcpy(&offset, data - sizeof offset, sizeof offset);
    ::operator delete (data - offset, std::align_val_t{kLine});
  }

private:
  static constexpr std::size_t kLine = 64;

  // 1 .. 63 cache lines, 8 lines on from one array to the next (8 and 63 share no factor: all 63
  // offsets come before one repeats).
  static std::size_t nextOffset()
  {
    static std::atomic<std::size_t> count{0};
    return kLine * (1 + (count.fetch_add(1, std::memory_order_relaxed) * 8) % 63);
  }
};

template <typename T, typename U>
bool operator==(const StaggeredAllocator<T>& /*a*/, const StaggeredAllocator<U>& /*b*/) noexcept
{
  return true;
}

template <typename T, typename U>
bool operator!=(const StaggeredAllocator<T>& /*a*/, const StaggeredAllocator<U>& /*b*/) noexcept
{
  return false;
}

/// A std::vector whose storage starts at a cache line of its own within a page (see above).
template <typename T>
using GridArray = std::vector<T, StaggeredAllocator<T>>;

}  // namespace grid_vision_fusion
