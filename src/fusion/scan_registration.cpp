#include "grid_vision_fusion/fusion/scan_registration.h"
#include "grid_vision_fusion/fusion/model_constants.h"

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>

namespace grid_vision_fusion
{
namespace
{
/// A normal distribution over the lattice: the probability mass of the cell at a shift [m].
class LatticeNormal
{
public:
  LatticeNormal(const Eigen::Vector2d& mean, const Eigen::Matrix2d& cov, double cell_area)
      : mean_(mean),
        information_(cov.inverse()),
        scale_(cell_area / (2.0 * M_PI * std::sqrt(cov.determinant())))
  {
  }

  /// At most 1 (a lattice cell much larger than the spread); 0 beyond kNegligibleSigmas standard
  /// deviations.
  double mass(const Eigen::Vector2d& shift) const
  {
    const Eigen::Vector2d d = shift - mean_;
    const double d2 = d.dot(information_ * d);
    return d2 > kNegligibleSigmas * kNegligibleSigmas ? 0.0 : std::min(1.0, scale_ * std::exp(-0.5 * d2));
  }

private:
  Eigen::Vector2d mean_;
  Eigen::Matrix2d information_;
  double scale_;
};
}  // namespace

ShiftVotes::ShiftVotes(const std::vector<Eigen::Vector2d>& then, const std::vector<Eigen::Vector2d>& now,
                       double cell_size, double max_shift)
    : cell_size_(cell_size)
{
  if (!(cell_size > 0.0) || !std::isfinite(cell_size) || !(max_shift >= 0.0) || then.size() < kMinHits ||
      now.size() < kMinHits || then.size() * now.size() > kMaxPairs)
  {
    return;
  }
  window_ = static_cast<int>(std::min(max_shift / cell_size, static_cast<double>(kMaxWindow)));
  const int side = 2 * window_ + 1;
  counts_.assign(static_cast<std::size_t>(side) * static_cast<std::size_t>(side), 0);
  // Lattice coordinates from a common origin (one of then's hits): a pair's shift is then the
  // difference of two integers, and hits off the lattice by a common offset (dynamic cells moved
  // to the image stamp) round alike.
  const auto first_finite =
      std::find_if(then.begin(), then.end(), [](const Eigen::Vector2d& hit) { return hit.allFinite(); });
  const Eigen::Vector2d origin = first_finite == then.end() ? Eigen::Vector2d::Zero() : *first_finite;
  auto latticeOf = [&](const std::vector<Eigen::Vector2d>& hits)
  {
    std::vector<Eigen::Vector2i> cells;
    cells.reserve(hits.size());
    for (const Eigen::Vector2d& hit : hits)
    {
      const Eigen::Vector2d c = ((hit - origin) / cell_size).array().round();
      if (c.allFinite() && c.cwiseAbs().maxCoeff() < 1e9)
      {
        cells.emplace_back(static_cast<int>(c.x()), static_cast<int>(c.y()));
      }
    }
    return cells;
  };
  const std::vector<Eigen::Vector2i> before = latticeOf(then);
  const std::vector<Eigen::Vector2i> after = latticeOf(now);
  for (const Eigen::Vector2i& b : after)
  {
    for (const Eigen::Vector2i& a : before)
    {
      const int dx = b.x() - a.x();
      const int dy = b.y() - a.y();
      if (std::abs(dx) > window_ || std::abs(dy) > window_)
      {
        continue;
      }
      const int index = (dy + window_) * side + dx + window_;
      int& count = counts_[static_cast<std::size_t>(index)];
      if (count++ == 0)
      {
        shifts_.push_back(index);
      }
      max_overlap_ = std::max(max_overlap_, count);
    }
  }
}

int ShiftVotes::overlap(int dx, int dy) const
{
  if (counts_.empty() || std::abs(dx) > window_ || std::abs(dy) > window_)
  {
    return 0;
  }
  return counts_[static_cast<std::size_t>((dy + window_) * (2 * window_ + 1) + dx + window_)];
}

double registrationLogRatio(const ShiftVotes& votes, double dt, const Eigen::Vector2d& velocity,
                            const Eigen::Matrix2d& velocity_cov, const Eigen::Matrix2d& unseen)
{
  const double cell = votes.cellSize();
  if (!(dt > 0.0) || votes.maxOverlap() == 0 || !velocity.allFinite() || !velocity_cov.allFinite() ||
      !unseen.allFinite())
  {
    return 0.0;
  }
  const double area = cell * cell;
  // Either mode's displacement is blurred by the lattice's quantisation and what the hits cannot show.
  const Eigen::Matrix2d blur = area / 6.0 * Eigen::Matrix2d::Identity() + unseen;
  const LatticeNormal standing_shift(Eigen::Vector2d::Zero(), blur, area);
  const LatticeNormal moving_shift(velocity * dt, dt * dt * velocity_cov + blur, area);
  // Σ_t P(t | mode) · exp(overlap(t) − max overlap): shifts without an overlap weigh
  // exp(−max overlap) each, i.e. that times the mass of the whole lattice (1) ...
  const double floor = std::exp(-kNatsPerHit * static_cast<double>(votes.maxOverlap()));
  double standing = floor;
  double moving = floor;
  // ... plus, for each shift with an overlap, its mass times the rest of its weight.
  votes.forEach(
      [&](int dx, int dy, int count)
      {
        const Eigen::Vector2d shift(dx * cell, dy * cell);
        const double standing_mass = standing_shift.mass(shift);
        const double moving_mass = moving_shift.mass(shift);
        if (standing_mass > 0.0 || moving_mass > 0.0)
        {
          const double extra =
              std::exp(kNatsPerHit * static_cast<double>(count - votes.maxOverlap())) - floor;
          standing += standing_mass * extra;
          moving += moving_mass * extra;
        }
      });
  constexpr double kTiny = 1e-300;
  return std::log(std::max(moving, kTiny)) - std::log(std::max(standing, kTiny));
}

double registrationReach(double cell_size, double dt, const Eigen::Vector2d& velocity,
                         const Eigen::Matrix2d& velocity_cov, const Eigen::Matrix2d& unseen)
{
  return dt * (velocity.norm() + kReachSigmas * std::sqrt(velocity_cov.trace())) +
         kReachSigmas * std::sqrt(unseen.trace()) + kReachCells * cell_size;
}

double registrationLogRatio(const std::vector<Eigen::Vector2d>& then, const std::vector<Eigen::Vector2d>& now,
                            double cell_size, double dt, const Eigen::Vector2d& velocity,
                            const Eigen::Matrix2d& velocity_cov, const Eigen::Matrix2d& unseen)
{
  const double reach = registrationReach(cell_size, dt, velocity, velocity_cov, unseen);
  return registrationLogRatio(ShiftVotes(then, now, cell_size, reach), dt, velocity, velocity_cov, unseen);
}

}  // namespace grid_vision_fusion
