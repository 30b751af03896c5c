#include "grid_vision_fusion/fusion/scan_registration.h"

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>

namespace grid_vision_fusion
{
namespace
{
/// Probability mass of the lattice cell at `shift` [m] (cell area `area` [m²]) under N(mean, cov),
/// at most 1.
double latticeMass(const Eigen::Vector2d& shift, const Eigen::Vector2d& mean, const Eigen::Matrix2d& cov,
                   double area)
{
  const Eigen::Vector2d d = shift - mean;
  const double density =
      std::exp(-0.5 * d.dot(cov.ldlt().solve(d))) / (2.0 * M_PI * std::sqrt(cov.determinant()));
  return std::min(1.0, density * area);
}
}  // namespace

ShiftVotes::ShiftVotes(const std::vector<Eigen::Vector2d>& then, const std::vector<Eigen::Vector2d>& now,
                       double cell_size, double max_shift)
    : cell_size_(cell_size)
{
  if (!(cell_size > 0.0) || !std::isfinite(cell_size) || !(max_shift >= 0.0) ||
      then.size() * now.size() > kMaxPairs)
  {
    return;
  }
  const double limit = std::min(max_shift / cell_size, static_cast<double>(kOffset - 1));
  for (const Eigen::Vector2d& b : now)
  {
    for (const Eigen::Vector2d& a : then)
    {
      const double dx = std::round((b.x() - a.x()) / cell_size);
      const double dy = std::round((b.y() - a.y()) / cell_size);
      if (!(std::abs(dx) <= limit) || !(std::abs(dy) <= limit))
      {
        continue;  // also NaN
      }
      const std::uint64_t key = (static_cast<std::uint64_t>(static_cast<int>(dx) + kOffset) << 32) |
                                static_cast<std::uint64_t>(static_cast<int>(dy) + kOffset);
      max_overlap_ = std::max(max_overlap_, ++counts_[key]);
    }
  }
}

int ShiftVotes::overlap(int dx, int dy) const
{
  const std::uint64_t key =
      (static_cast<std::uint64_t>(dx + kOffset) << 32) | static_cast<std::uint64_t>(dy + kOffset);
  const auto it = counts_.find(key);
  return it == counts_.end() ? 0 : it->second;
}

double registrationLogRatio(const ShiftVotes& votes, double dt, const Eigen::Vector2d& velocity,
                            const Eigen::Matrix2d& velocity_cov)
{
  const double cell = votes.cellSize();
  if (!(dt > 0.0) || votes.maxOverlap() == 0 || !velocity.allFinite() || !velocity_cov.allFinite())
  {
    return 0.0;
  }
  const double area = cell * cell;
  const Eigen::Matrix2d quantisation = area / 6.0 * Eigen::Matrix2d::Identity();
  const Eigen::Vector2d moving_mean = velocity * dt;
  const Eigen::Matrix2d moving_cov = dt * dt * velocity_cov + quantisation;
  // Σ_t P(t | mode) · exp(overlap(t) − max overlap): shifts without an overlap weigh
  // exp(−max overlap) each, i.e. that times the mass of the whole lattice (1) ...
  const double floor = std::exp(-static_cast<double>(votes.maxOverlap()));
  double standing = floor;
  double moving = floor;
  // ... plus, for each shift with an overlap, its mass times the rest of its weight.
  votes.forEach(
      [&](int dx, int dy, int count)
      {
        const Eigen::Vector2d shift(dx * cell, dy * cell);
        const double extra = std::exp(static_cast<double>(count - votes.maxOverlap())) - floor;
        standing += latticeMass(shift, Eigen::Vector2d::Zero(), quantisation, area) * extra;
        moving += latticeMass(shift, moving_mean, moving_cov, area) * extra;
      });
  constexpr double kTiny = 1e-300;
  return std::log(std::max(moving, kTiny)) - std::log(std::max(standing, kTiny));
}

}  // namespace grid_vision_fusion
