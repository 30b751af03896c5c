// Deterministic block parallelism for the grid (doc/grid_filter.md, "Determinism"): work is cut
// into blocks of a fixed size that does not depend on the thread count, every block does the same
// work whatever thread runs it, and each block draws its random numbers from its own stream,
// seeded from (seed, cycle, pass, block). The output is then bit-identical for any thread count.
#pragma once

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/partitioner.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <vector>

#include "grid_vision_fusion/splitmix64.h"

namespace grid_vision_fusion
{
/// Runs f(block) for block = 0 .. blocks - 1: inline and in order with one thread, otherwise in a
/// tbb::task_arena of `threads` threads (one block per task, tbb::simple_partitioner).
class ParallelBlocks
{
public:
  /// `threads`: 0 = all cores (tbb::info::default_concurrency()), 1 = serial, inline.
  explicit ParallelBlocks(int threads = 1);

  /// The number of threads the blocks run on (>= 1).
  int threads() const { return threads_; }

  template <typename F>
  void run(std::size_t blocks, const F& f) const
  {
    if (threads_ == 1 || blocks <= 1)
    {
      for (std::size_t b = 0; b < blocks; ++b)
      {
        f(b);
      }
      return;
    }
    arena_->execute(
        [&]
        {
          tbb::parallel_for(
              tbb::blocked_range<std::size_t>(0, blocks, 1),
              [&](const tbb::blocked_range<std::size_t>& range)
              {
                for (std::size_t b = range.begin(); b != range.end(); ++b)
                {
                  f(b);
                }
              },
              tbb::simple_partitioner());
        });
  }

private:
  int threads_ = 1;
  std::unique_ptr<tbb::task_arena> arena_;
};

/// Number of blocks of `block` items that cover `items`.
inline std::size_t blockCount(std::size_t items, std::size_t block)
{
  return (items + block - 1) / block;
}

/// Sets every element of `v` to `value`, in blocks of 2^15 elements on the threads of `parallel`.
template <typename Vector>
void parallelFill(const ParallelBlocks& parallel, Vector& v, const typename Vector::value_type& value)
{
  constexpr std::size_t kBlock = std::size_t{1} << 15;
  parallel.run(blockCount(v.size(), kBlock),
               [&](std::size_t b)
               {
                 const auto begin = static_cast<std::ptrdiff_t>(b * kBlock);
                 const auto end = static_cast<std::ptrdiff_t>(std::min(v.size(), (b + 1) * kBlock));
                 std::fill(v.begin() + begin, v.begin() + end, value);
               });
}

/// A random stream (SplitMix64) for one block of one pass of one cycle: the same (seed, cycle,
/// pass, block) always gives the same numbers, whatever thread draws them.
class BlockRandom
{
public:
  BlockRandom(std::uint32_t seed, std::uint64_t cycle, std::uint32_t pass, std::uint64_t block)
      : random_(SplitMix64::mix(SplitMix64::mix(SplitMix64::mix(0x5EEDF00DULL + seed) ^ cycle) ^
                                ((static_cast<std::uint64_t>(pass) << 48) + block)))
  {
  }

  /// 64 random bits.
  std::uint64_t next() { return random_.next(); }

  /// 16 random bits (four per call of next()).
  std::uint32_t bits16()
  {
    if (spare_count_ == 0)
    {
      spare_ = next();
      spare_count_ = 4;
    }
    const auto v = static_cast<std::uint32_t>(spare_ & 0xFFFFU);
    spare_ >>= 16;
    --spare_count_;
    return v;
  }

  /// Uniform in [0, 1) with 24 bits.
  float uniform() { return static_cast<float>(next() >> 40) * (1.0F / 16777216.0F); }

private:
  SplitMix64 random_;
  std::uint64_t spare_ = 0;
  int spare_count_ = 0;
};

}  // namespace grid_vision_fusion
