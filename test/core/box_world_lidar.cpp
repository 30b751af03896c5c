#include "box_world_lidar.h"

#include <cmath>
#include <limits>

namespace grid_vision_fusion
{
namespace testing
{
namespace
{
constexpr double kDeg = M_PI / 180.0;

// Ray-box intersection (slab method) in the box frame; returns the entry distance or +inf.
double intersectBox(const Eigen::Vector3d& origin, const Eigen::Vector3d& dir, const Box& box,
                    double ground_z, double c, double s)
{
  const Eigen::Vector3d rel(origin.x() - box.x, origin.y() - box.y, origin.z() - (ground_z + box.bottom));
  const Eigen::Vector3d o(c * rel.x() + s * rel.y(), -s * rel.x() + c * rel.y(), rel.z());
  const Eigen::Vector3d d(c * dir.x() + s * dir.y(), -s * dir.x() + c * dir.y(), dir.z());
  const Eigen::Vector3d lo(-0.5 * box.length, -0.5 * box.width, 0.0);
  const Eigen::Vector3d hi(0.5 * box.length, 0.5 * box.width, box.height);
  double t_min = 0.0;
  double t_max = std::numeric_limits<double>::infinity();
  for (int k = 0; k < 3; ++k)
  {
    if (std::fabs(d[k]) < 1e-12)
    {
      if (o[k] < lo[k] || o[k] > hi[k])
      {
        return std::numeric_limits<double>::infinity();
      }
      continue;
    }
    double t0 = (lo[k] - o[k]) / d[k];
    double t1 = (hi[k] - o[k]) / d[k];
    if (t0 > t1)
    {
      std::swap(t0, t1);
    }
    t_min = std::max(t_min, t0);
    t_max = std::min(t_max, t1);
    if (t_min > t_max)
    {
      return std::numeric_limits<double>::infinity();
    }
  }
  return t_min > 0.0 ? t_min : std::numeric_limits<double>::infinity();
}
}  // namespace

BoxWorldLidar::BoxWorldLidar(const BoxWorldLidarConfig& config) : config_(config), noise_state_(config.seed)
{
  const int columns = static_cast<int>(std::lround(360.0 / config_.horizontal_resolution_deg));
  for (int col = 0; col < columns; ++col)
  {
    const double az = (col * config_.horizontal_resolution_deg) * kDeg;
    for (double el_deg : hdl64Elevations())
    {
      const double el = el_deg * kDeg;
      directions_.emplace_back(std::cos(el) * std::cos(az), std::cos(el) * std::sin(az), std::sin(el));
    }
  }
}

std::vector<double> BoxWorldLidar::hdl64Elevations()
{
  std::vector<double> el;
  for (int i = 0; i < 32; ++i)
  {
    el.push_back(2.0 - i * (1.0 / 3.0));
  }
  for (int i = 0; i < 32; ++i)
  {
    el.push_back(-8.83 - i * 0.5);
  }
  return el;
}

std::vector<float> BoxWorldLidar::scan(const Eigen::Isometry3d& world_from_sensor,
                                       const std::vector<Box>& boxes)
{
  std::vector<float> points;
  points.reserve(directions_.size() * 3);
  const Eigen::Matrix3d rot = world_from_sensor.linear();
  const Eigen::Vector3d origin = world_from_sensor.translation();
  // Ground plane z = h + a x  <=>  n . p = h with n = (-a, 0, 1).
  const Eigen::Vector3d n(-config_.ground_slope_x, 0.0, 1.0);
  std::vector<double> cos_yaw;
  std::vector<double> sin_yaw;
  std::vector<double> box_ground;
  for (const Box& box : boxes)
  {
    cos_yaw.push_back(std::cos(box.yaw));
    sin_yaw.push_back(std::sin(box.yaw));
    box_ground.push_back(groundZ(box.x, box.y));
  }
  for (const Eigen::Vector3d& ds : directions_)
  {
    const Eigen::Vector3d dw = rot * ds;
    double t = std::numeric_limits<double>::infinity();
    const double nd = n.dot(dw);
    if (nd < -1e-12)
    {
      const double tg = (config_.ground_height - n.dot(origin)) / nd;
      if (tg > 0.0)
      {
        t = tg;
      }
    }
    for (std::size_t b = 0; b < boxes.size(); ++b)
    {
      t = std::min(t, intersectBox(origin, dw, boxes[b], box_ground[b], cos_yaw[b], sin_yaw[b]));
    }
    if (!(t <= config_.max_range))
    {
      continue;
    }
    if (config_.range_noise_sigma > 0.0)
    {
      // Box-Muller on a splitmix64 stream: deterministic for the seed.
      auto next = [this]
      {
        std::uint64_t z = (noise_state_ += 0x9E3779B97F4A7C15ULL);
        z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
        z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
        return (static_cast<double>((z ^ (z >> 31)) >> 11) + 0.5) / 9007199254740992.0;
      };
      t += config_.range_noise_sigma * std::sqrt(-2.0 * std::log(next())) * std::cos(2.0 * M_PI * next());
    }
    const Eigen::Vector3d p = ds * t;
    points.push_back(static_cast<float>(p.x()));
    points.push_back(static_cast<float>(p.y()));
    points.push_back(static_cast<float>(p.z()));
  }
  return points;
}

Eigen::Isometry3d sensorPose(double x, double y, double z, double yaw)
{
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  pose.translation() = Eigen::Vector3d(x, y, z);
  return pose;
}

}  // namespace testing
}  // namespace grid_vision_fusion
