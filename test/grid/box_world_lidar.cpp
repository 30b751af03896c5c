#include "box_world_lidar.h"

#include <cmath>

namespace grid_vision_fusion
{
namespace testing
{
BoxWorldLidar::BoxWorldLidar(const BoxWorldLidarConfig& config) : rng_(config.seed)
{
  lidar_.azimuth_steps = static_cast<int>(std::lround(360.0 / config.horizontal_resolution_deg));
  lidar_.min_range = 0.05;
  lidar_.max_range = config.max_range;
  lidar_.range_noise_std = config.range_noise_sigma;
  lidar_.dropout = 0.0;
  ground_.height = config.ground_height;
  ground_.slope_x = config.ground_slope_x;
}

std::vector<float> BoxWorldLidar::scan(const Eigen::Isometry3d& world_from_sensor,
                                       const std::vector<Box>& boxes)
{
  std::vector<Actor> actors;
  actors.reserve(boxes.size());
  for (const Box& box : boxes)
  {
    Actor actor;
    actor.length = box.length;
    actor.width = box.width;
    actor.height = box.height;
    actor.trajectory = Trajectory::parked({box.x, box.y, box.yaw});
    actors.push_back(actor);
  }
  const SceneSnapshot scene(actors, {}, 0.0, ground_);
  std::vector<float> xyz;
  for (const LidarPoint& p : simulateLidarScan(scene, world_from_sensor, lidar_, rng_))
  {
    xyz.insert(xyz.end(), {p.x, p.y, p.z});
  }
  return xyz;
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
