// The parts of the dynamic grid filter (doc/grid_filter.md) that more than one of its steps uses:
// the block sizes of the parallel passes, the constants and helpers shared by the steps, and the
// member templates that walk the rows of the grid and the particles. The steps: construction,
// update() and the grid's move in src/grid/dynamic_grid_filter.cpp, the cell update in
// src/grid/dynamic_grid_cells.cpp, the motion evidence in src/grid/dynamic_grid_motion.cpp, the
// particles in src/grid/dynamic_grid_particles.cpp. Private to src/grid (not installed).
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "grid_vision_fusion/grid/dynamic_grid_filter.h"

namespace grid_vision_fusion
{
namespace dynamic_grid_detail
{
constexpr int kBucket = 8;  // vacated cells are bucketed in squares of kBucket x kBucket cells
// Motion evidence (doc/grid_filter.md, "Motion evidence").
constexpr float kEvidenceGate = 0.3F;          // evidence from which a cell counts as moving
constexpr float kMinVelocityVariance = 0.01F;  // [m^2/s^2] floor of var_x, var_y in m^2
// Blocks of the parallel passes (doc/grid_filter.md, "Determinism"): fixed sizes, independent of
// the thread count, so every block does the same work and draws the same random numbers.
constexpr std::size_t kParticleBlock = 4096;  // particles per block
constexpr int kRowBlock = 8;                  // grid rows per block (and per band of the particle sort)

// Significance of a mean velocity: vx^2 / var_x + vy^2 / var_y (variances floored).
inline float velocitySignificance(float vx, float vy, float var_x, float var_y)
{
  return vx * vx / std::max(var_x, kMinVelocityVariance) + vy * vy / std::max(var_y, kMinVelocityVariance);
}

// Probability of an event of probability `per_period` within transition_period, over dt.
inline float perInterval(double per_period, double dt, double period)
{
  if (per_period <= 0.0 || dt <= 0.0)
  {
    return 0.0F;
  }
  return static_cast<float>(1.0 - std::pow(1.0 - per_period, dt / period));
}

// Standard normal quantiles at the centres of 2^16 equal-probability slices (defined with the
// particles, src/grid/dynamic_grid_particles.cpp).
const std::vector<float>& normalTable();

// Off-diagonal transition probabilities of one row scaled to dt (eq. 2): the probability of
// leaving the state, q = sum(eps), becomes 1 - (1 - q)^(dt / T), shared in the same proportions.
struct Row
{
  float stay = 1.0F;
  std::array<float, 3> to{};
};

inline Row scaledRow(std::array<double, 3> eps, double dt, double period)
{
  Row row;
  const double q = eps[0] + eps[1] + eps[2];
  if (q <= 0.0 || dt <= 0.0)
  {
    return row;
  }
  const double q_dt = 1.0 - std::pow(1.0 - q, dt / period);
  for (std::size_t k = 0; k < 3; ++k)
  {
    row.to[k] = static_cast<float>(eps[k] / q * q_dt);
  }
  row.stay = static_cast<float>(1.0 - q_dt);
  return row;
}
}  // namespace dynamic_grid_detail

template <typename F>
void DynamicGridFilter::forParticlesByCellPart(const F& f) const
{
  const std::int32_t* cell = particles_.cell.data();
  const std::size_t n = particles_.size();
  const auto band_cells = static_cast<std::int32_t>(dynamic_grid_detail::kRowBlock * geometry_.width);
  parallel_.run(part_band_.size() - 1,
                [&](std::size_t part)
                {
                  const auto begin = static_cast<std::int32_t>(part_band_[part]) * band_cells;
                  const auto end = static_cast<std::int32_t>(part_band_[part + 1]) * band_cells;
                  for (std::size_t i = 0; i < n; ++i)
                  {
                    if (cell[i] >= begin && cell[i] < end)
                    {
                      f(i);
                    }
                  }
                });
}

template <typename F>
void DynamicGridFilter::forRowBlocks(const F& f) const
{
  const int h = geometry_.height;
  parallel_.run(blockCount(static_cast<std::size_t>(h), dynamic_grid_detail::kRowBlock),
                [&](std::size_t b)
                {
                  const int r0 = static_cast<int>(b) * dynamic_grid_detail::kRowBlock;
                  f(b, r0, std::min(h, r0 + dynamic_grid_detail::kRowBlock));
                });
}

}  // namespace grid_vision_fusion
