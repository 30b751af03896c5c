// SplitMix64: the counter-based random generator of the grid filter's particles and of the
// detection noise (Steele, Lea and Flood, "Fast splittable pseudorandom number generators", 2014).
#pragma once

#include <cstdint>

namespace grid_vision_fusion
{
/// A 64-bit state advanced by the golden-ratio increment and passed through a bijective mix: the
/// same seed gives the same numbers with every compiler and standard library, and seeds that differ
/// in one bit give unrelated streams.
class SplitMix64
{
public:
  static constexpr std::uint64_t kIncrement = 0x9E3779B97F4A7C15ULL;

  explicit SplitMix64(std::uint64_t state = 0) : state_(state) {}

  /// The bijective finaliser of SplitMix64 (also a good hash of a 64-bit key).
  static constexpr std::uint64_t mix(std::uint64_t z)
  {
    z = (z ^ (z >> 30U)) * 0xBF58476D1CE4E5B9ULL;
    z = (z ^ (z >> 27U)) * 0x94D049BB133111EBULL;
    return z ^ (z >> 31U);
  }

  /// The next 64 random bits.
  std::uint64_t next()
  {
    state_ += kIncrement;
    return mix(state_);
  }

private:
  std::uint64_t state_;
};

}  // namespace grid_vision_fusion
