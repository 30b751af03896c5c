// Test fixture: a box world for the grid tests. Boxes standing on a ground plane (optionally
// sloped along x), scanned by the simulator's HDL-64E lidar (simulateLidarScan() of the
// simulation library) with a configurable horizontal resolution and no dropouts. Returns the
// points in the sensor frame, packed x, y, z, as the filter's PointCloudView::packedXyz() takes them.
#pragma once

#include <Eigen/Geometry>

#include <cstdint>
#include <random>
#include <vector>

#include "grid_vision_fusion/simulation/synthetic_world.h"

namespace grid_vision_fusion
{
namespace testing
{
/// A box: centre of its footprint at (x, y) [m] on the ground, size along its own axes [m],
/// yaw about +z [rad].
struct Box
{
  double x = 0.0;
  double y = 0.0;
  double length = 4.0;  ///< along its x axis [m]
  double width = 2.0;   ///< along its y axis [m]
  double height = 1.5;  ///< [m]
  double yaw = 0.0;
};

struct BoxWorldLidarConfig
{
  double horizontal_resolution_deg = 0.5;  ///< azimuth step [deg]
  double max_range = 120.0;                ///< rays that hit nothing closer give no point [m]
  double ground_height = 0.0;              ///< ground z at x = 0 [m]
  double ground_slope_x = 0.0;             ///< dz/dx of the ground plane
  double range_noise_sigma = 0.0;          ///< Gaussian range noise [m]
  std::uint32_t seed = 7;
};

class BoxWorldLidar
{
public:
  explicit BoxWorldLidar(const BoxWorldLidarConfig& config = BoxWorldLidarConfig());

  /// One revolution from the sensor at `world_from_sensor`: one point per ray that hits the
  /// ground or a box within max_range, in the sensor frame, packed x, y, z.
  std::vector<float> scan(const Eigen::Isometry3d& world_from_sensor, const std::vector<Box>& boxes);

  /// Ground z at (x, y) [m].
  double groundZ(double x, double /*y*/) const { return ground_.z(x); }

private:
  LidarConfig lidar_;
  GroundPlane ground_;
  std::mt19937 rng_;
};

/// Pose of a sensor at (x, y, z) with yaw [rad], no roll or pitch.
Eigen::Isometry3d sensorPose(double x, double y, double z, double yaw = 0.0);

}  // namespace testing
}  // namespace grid_vision_fusion
