// Test helper: a box-world lidar simulator. A ground plane (optionally sloped) and boxes
// standing on it, scanned by a 64-beam lidar with the vertical layout of a Velodyne HDL-64E
// and a configurable horizontal resolution. Returns the points in the sensor frame, as a
// driver would publish them.
#pragma once

#include <Eigen/Geometry>

#include <cstdint>
#include <vector>

namespace grid_vision_fusion
{
namespace testing
{
/// A box: centre of its footprint at (x, y) [m] on the ground, size along its own axes [m],
/// yaw about +z [rad]. Its bottom is at ground level of (x, y) plus `bottom` [m].
struct Box
{
  double x = 0.0;
  double y = 0.0;
  double length = 4.0;  ///< along its x axis [m]
  double width = 2.0;   ///< along its y axis [m]
  double height = 1.5;  ///< [m]
  double yaw = 0.0;
  double bottom = 0.0;
};

struct BoxWorldLidarConfig
{
  double horizontal_resolution_deg = 0.5;  ///< azimuth step [deg]
  double max_range = 120.0;                ///< rays that hit nothing closer give no point [m]
  double ground_height = 0.0;              ///< ground z at x = y = 0 [m]
  double ground_slope_x = 0.0;             ///< dz/dx of the ground plane
  double range_noise_sigma = 0.0;          ///< Gaussian range noise [m]
  std::uint32_t seed = 7;
};

class BoxWorldLidar
{
public:
  explicit BoxWorldLidar(const BoxWorldLidarConfig& config = BoxWorldLidarConfig());

  /// The 64 beam elevations of an HDL-64E [deg]: 32 upper beams from +2 to -8.33 by 1/3 deg,
  /// 32 lower beams from -8.83 to -24.33 by 1/2 deg.
  static std::vector<double> hdl64Elevations();

  /// One revolution from the sensor at `world_from_sensor`: one point per ray that hits the
  /// ground or a box within max_range, in the sensor frame, packed x, y, z.
  std::vector<float> scan(const Eigen::Isometry3d& world_from_sensor, const std::vector<Box>& boxes);

  /// Ground z at (x, y) [m].
  double groundZ(double x, double /*y*/) const { return config_.ground_height + config_.ground_slope_x * x; }

private:
  BoxWorldLidarConfig config_;
  std::vector<Eigen::Vector3d> directions_;  // sensor frame, unit
  std::uint64_t noise_state_;
};

/// Pose of a sensor at (x, y, z) with yaw [rad], no roll or pitch.
Eigen::Isometry3d sensorPose(double x, double y, double z, double yaw = 0.0);

}  // namespace testing
}  // namespace grid_vision_fusion
