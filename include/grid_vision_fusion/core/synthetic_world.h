// A synthetic road world for test drives with exact ground truth: a flat ground plane, static
// scenery boxes (buildings, walls), and actors (cars, vans, cyclists...) that follow
// trajectories; ray casting against it simulates an HDL-64E lidar and a camera.
//
// Frames: the world frame is z-up with the ground plane at z = 0. Boxes stand on their bottom
// face; their yaw turns the length axis (local x) away from world x, counter-clockwise.
#pragma once

#include <Eigen/Geometry>

#include <cstdint>
#include <limits>
#include <random>
#include <string>
#include <vector>

namespace grid_vision_fusion
{
/// A planar pose on the ground: position [m] and yaw [rad] in the world frame.
struct Pose2D
{
  double x = 0.0;
  double y = 0.0;
  double yaw = 0.0;
};

/// A time-parametrised planar trajectory.
class Trajectory
{
public:
  /// Piecewise-linear motion through (t [s], x [m], y [m]) waypoints sorted by time. Before the
  /// first and after the last waypoint the object stands still. The yaw follows the direction
  /// of motion and is kept while standing (initially `initial_yaw`, used when the object never
  /// moves). @throws std::invalid_argument when empty or times are not strictly increasing.
  static Trajectory waypoints(const std::vector<Eigen::Vector3d>& t_x_y, double initial_yaw = 0.0);
  /// Constant speed [m/s] and turn rate [rad/s] from `start` at t = 0 (exact circular arcs).
  static Trajectory constantTurn(const Pose2D& start, double speed, double yaw_rate);
  /// Standing still at `pose`.
  static Trajectory parked(const Pose2D& pose);
  /// Piecewise-linear motion through full poses (position and yaw) at strictly increasing
  /// `times` [s]; the yaw is interpolated along the shorter arc (e.g. recorded tracklets).
  /// @throws std::invalid_argument when empty, sizes differ or times do not increase.
  static Trajectory posed(const std::vector<double>& times, const std::vector<Pose2D>& poses);

  Pose2D poseAt(double t) const;
  /// Velocity over ground [m/s] in the world frame.
  Eigen::Vector2d velocityAt(double t) const;

private:
  enum class Kind
  {
    kWaypoints,
    kConstantTurn,
  } kind_ = Kind::kWaypoints;
  std::vector<Eigen::Vector3d> waypoints_;
  std::vector<double> segment_yaw_;   ///< yaw held at the end of each segment
  std::vector<double> waypoint_yaw_;  ///< explicit yaw per waypoint (posed()), else empty
  Pose2D start_;
  double speed_ = 0.0;
  double yaw_rate_ = 0.0;
};

/// An oriented box standing on the ground.
struct GroundBox
{
  Pose2D pose;          ///< centre of the bottom face and heading
  double length = 4.0;  ///< along the heading [m]
  double width = 1.8;   ///< [m]
  double height = 1.5;  ///< [m]

  /// The 8 corners in the world frame: bottom 4 (counter-clockwise from front-left), then top 4.
  std::vector<Eigen::Vector3d> corners() const;
};

/// A moving or static object of the scene.
struct Actor
{
  std::string type;  ///< KITTI type: "Car", "Van", "Truck", "Cyclist", "Pedestrian"...
  double length = 4.0, width = 1.8, height = 1.5;  ///< [m]
  Trajectory trajectory = Trajectory::parked({});
  std::uint32_t color_rgb = 0x2E5FA8;  ///< body colour for the camera, 0xRRGGBB
  /// The actor exists only for active_from <= t <= active_until [s] (e.g. a recorded tracklet);
  /// outside it neither the lidar nor the camera sees it.
  double active_from = -std::numeric_limits<double>::infinity();
  double active_until = std::numeric_limits<double>::infinity();

  GroundBox boxAt(double t) const;
  bool activeAt(double t) const { return t >= active_from && t <= active_until; }
};

/// Static scenery: buildings, walls, parked trailers... (not labelled).
struct SceneryBox
{
  GroundBox box;
  std::uint32_t color_rgb = 0x808080;  ///< 0xRRGGBB
};

/// What a ray hit.
struct RayHit
{
  double range = std::numeric_limits<double>::infinity();  ///< along the unit direction [m]
  int object = kNothing;  ///< actor index, or kGround / kScenery + index / kNothing
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();  ///< world-frame normal of the hit surface

  static constexpr int kNothing = -1;
  static constexpr int kGround = -2;
  static constexpr int kSceneryBase = 1000000;  ///< scenery i is reported as kSceneryBase + i
  bool hit() const { return object != kNothing; }
};

/// Slab intersection of a ray with a box. Returns the entry range (> min_range) and the normal of
/// the entry face, or an infinite range when missed.
RayHit intersectBox(const GroundBox& box, const Eigen::Vector3d& origin, const Eigen::Vector3d& direction,
                    double min_range = 1e-6);

/// The world at one instant: ground, scenery and actor boxes.
class SceneSnapshot
{
public:
  SceneSnapshot(const std::vector<Actor>& actors, const std::vector<SceneryBox>& scenery, double t);

  /// Leaves every box whose bounding sphere lies entirely farther than `radius` [m] from the
  /// ground point `centre` out of cast() and actorsAlong() (a sensor there cannot see it within
  /// that range): long drives with many objects stay fast to simulate. Indices are unchanged.
  void cullBeyond(const Eigen::Vector2d& centre, double radius);

  /// Nearest hit of a ray (unit `direction`) within (min_range, max_range].
  RayHit cast(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction, double min_range,
              double max_range) const;
  /// Every actor box the ray passes through within (min_range, max_range], whether hidden or
  /// not (for the occlusion of labels). Appends actor indices to `actors`.
  void actorsAlong(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction, double min_range,
                   double max_range, std::vector<int>& actors) const;

  const std::vector<GroundBox>& actorBoxes() const { return actor_boxes_; }
  /// Whether actor i exists at the snapshot's time.
  bool actorActive(std::size_t i) const { return actor_active_[i]; }
  const std::vector<GroundBox>& sceneryBoxes() const { return scenery_boxes_; }

private:
  std::vector<GroundBox> actor_boxes_;
  std::vector<bool> actor_active_;
  std::vector<GroundBox> scenery_boxes_;
  std::vector<bool> culled_;          ///< per box (actors then scenery), see cullBeyond()
  std::vector<double> bound_radius_;  ///< per box (actors then scenery), for a quick rejection
};

/// A rotating multi-beam lidar. Defaults: Velodyne HDL-64E S2 as in KITTI.
struct LidarConfig
{
  /// Beam elevations [rad], top to bottom. Empty: the HDL-64E layout, upper block +2° to
  /// −8.33° in 1/3° steps (32 beams), lower block −8.83° to −24.33° in 1/2° steps (32 beams).
  std::vector<double> elevations;
  int azimuth_steps = 2048;       ///< columns per revolution (0.176°)
  double min_range = 2.5;         ///< closer returns are discarded [m]
  double max_range = 120.0;       ///< [m]
  double range_noise_std = 0.02;  ///< Gaussian range noise [m]
  double dropout = 0.02;          ///< probability that a return is lost, [0, 1)

  /// The HDL-64E elevations described above.
  static std::vector<double> hdl64Elevations();
  /// @throws std::invalid_argument naming the bad field.
  void validate() const;
};

/// One simulated return in the sensor frame (x forward, y left, z up).
struct LidarPoint
{
  float x, y, z;
  float intensity;  ///< [0, 1]: larger on near, face-on surfaces
};

/// Casts every beam of one revolution from `sensor_pose` (sensor frame → world) into `scene`,
/// adding range noise and dropouts from `rng`. The scan is instantaneous (no rolling shutter).
std::vector<LidarPoint> simulateLidarScan(const SceneSnapshot& scene, const Eigen::Isometry3d& sensor_pose,
                                          const LidarConfig& config, std::mt19937& rng);

}  // namespace grid_vision_fusion
