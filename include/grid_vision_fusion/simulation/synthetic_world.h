// A synthetic road world for test drives with exact ground truth: the ground (flat, or a height
// field with a slope, a cambered road, kerbs and verges), static scenery boxes (buildings, walls),
// and actors (cars, vans, cyclists...) that follow trajectories, each a box or a vehicle's
// profile inside its box; ray casting against it simulates an HDL-64E lidar and a camera.
//
// Frames: the world frame is z-up with the ground at z = 0 (or the height field of
// GroundSurface). Boxes stand on their bottom face; their yaw turns the length axis (local x) away
// from world x, counter-clockwise.
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

/// What the lidar and the camera see of an actor inside its (labelled) box.
enum class VehicleShape
{
  kBox,  ///< the box itself
  /// A car's profile: a lower body with rounded corners in plan view whose bonnet falls towards
  /// the front and whose boot towards the rear, and above it a narrower, shorter cabin with a raked
  /// windscreen and rear window; the cabin's sides, windscreen and rear window are glass, its roof
  /// is not.
  kCar,
  /// A van's profile: a short bonnet, a tall body over the whole length behind a raked windscreen,
  /// rounded front corners; glass in the windscreen and the cab's side windows only.
  kVan,
};

/// The shape's name in scenario files: "box", "car", "van".
const char* vehicleShapeName(VehicleShape shape);

/// An oriented box standing on the ground.
struct GroundBox
{
  Pose2D pose;                              ///< centre of the bottom face and heading
  double length = 4.0;                      ///< along the heading [m]
  double width = 1.8;                       ///< [m]
  double height = 1.5;                      ///< [m]
  double base_z = 0.0;                      ///< z of the bottom face [m] (0: on the flat ground)
  VehicleShape shape = VehicleShape::kBox;  ///< what the sensors see inside the box
  double glass_transmission = 0.5;  ///< share of lidar beams a window lets through, [0, 1] (kCar, kVan)

  /// The 8 corners in the world frame: bottom 4 (counter-clockwise from front-left), then top 4.
  std::vector<Eigen::Vector3d> corners() const;
};

/// A moving or static object of the scene.
struct Actor
{
  std::string type;  ///< KITTI type: "Car", "Van", "Truck", "Cyclist", "Pedestrian"...
  double length = 4.0, width = 1.8, height = 1.5;  ///< [m]
  Trajectory trajectory = Trajectory::parked({});
  std::uint32_t color_rgb = 0x2E5FA8;       ///< body colour for the camera, 0xRRGGBB
  VehicleShape shape = VehicleShape::kBox;  ///< what the sensors see inside the box
  double glass_transmission = 0.5;          ///< share of lidar beams a window lets through, [0, 1]
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
  bool glass = false;  ///< the surface is a vehicle's window (VehicleShape kCar, kVan)

  static constexpr int kNothing = -1;
  static constexpr int kGround = -2;
  static constexpr int kSceneryBase = 1000000;  ///< scenery i is reported as kSceneryBase + i
  bool hit() const { return object != kNothing; }
};

/// Slab intersection of a ray with a box. Returns the entry range (> min_range) and the normal of
/// the entry face, or an infinite range when missed.
RayHit intersectBox(const GroundBox& box, const Eigen::Vector3d& origin, const Eigen::Vector3d& direction,
                    double min_range = 1e-6);

/// The surfaces of a vehicle's profile (VehicleShape kCar, kVan) in its box, for ray casting:
/// two convex parts (the lower body, and the cabin or upper body) within length × width × height.
class VehicleBody
{
public:
  /// The profile `shape` (kCar or kVan) scaled to the box [m]. @throws std::invalid_argument for kBox.
  VehicleBody(VehicleShape shape, double length, double width, double height);

  /// Nearest surface along the ray (unit `direction`) beyond `min_range` for the body standing in
  /// `box` (its pose and base_z). A window passes the beam when `glass_draw` < `transmission`;
  /// the beam then meets the interior or the window of the other side, which passes it when
  /// glass_draw / transmission < transmission, and so on (glass_draw uniform in [0, 1): each
  /// window passes a share `transmission` of the beams; glass_draw ≥ 1: windows are opaque).
  /// `hit.object` is 0 when something was hit.
  RayHit intersect(const GroundBox& box, const Eigen::Vector3d& origin, const Eigen::Vector3d& direction,
                   double min_range, double glass_draw, double transmission) const;
  /// Whether the ray enters the body (windows included) within (min_range, max_range].
  bool crosses(const GroundBox& box, const Eigen::Vector3d& origin, const Eigen::Vector3d& direction,
               double min_range, double max_range) const;

  /// One face of a convex part: inside where normal · p <= offset (box frame: x forward from the
  /// box centre, y left, z up from its bottom).
  struct Face
  {
    Eigen::Vector3d normal;
    double offset = 0.0;
    bool glass = false;          ///< a window (where the hit's x >= glass_from_x)
    double glass_from_x = -1e9;  ///< [m] box frame: the window starts here (a van's cab)
  };
  using Part = std::vector<Face>;

private:
  Part lower_;
  Part upper_;
};

/// The shape's surface along a ray: intersectBox() for kBox, VehicleBody::intersect() otherwise
/// (see there for `glass_draw`).
RayHit intersectShape(const GroundBox& box, const Eigen::Vector3d& origin, const Eigen::Vector3d& direction,
                      double min_range = 1e-6, double glass_draw = 1.0);

/// The ground: the plane z = height + slope_x · x (flat at z = 0 by default), optionally with a
/// road profile across world y: a road from center_y − half_width to center_y + half_width whose
/// surface falls by `camber` from its centre line towards both edges, a kerb of kerb_height at
/// each edge, and beyond each kerb a verge that rises by verge_rise_left (y > center_y) or
/// verge_rise_right over verge_width and then stays level. Without a profile (camber, kerb
/// and verge rises 0) the ground is the plane, computed exactly as before the profile existed.
struct GroundSurface
{
  double height = 0.0;            ///< z at x = 0 on the road's centre line [m]
  double slope_x = 0.0;           ///< dz/dx (a slope along the road)
  double center_y = 0.0;          ///< world y of the road's centre line, the crown of the camber [m]
  double half_width = 7.0;        ///< the kerbs stand at center_y ± half_width [m] (> 0)
  double camber = 0.0;            ///< fall of the road from its centre line to its edges [m/m] (>= 0)
  double kerb_height = 0.0;       ///< step up at both road edges [m] (>= 0)
  double verge_rise_left = 0.0;   ///< rise beyond the left kerb top (y > center_y) [m] (>= 0)
  double verge_rise_right = 0.0;  ///< rise beyond the right kerb top [m] (>= 0)
  double verge_width = 3.0;       ///< over which the verges rise [m] (> 0)

  /// Whether there is a road profile (else the plane).
  bool profiled() const;
  /// Ground height at world (x, y) [m] (beyond a kerb: the verge's).
  double z(double x, double y) const;
  /// Ground height on the road's centre line at world x [m] (the plane).
  double z(double x) const { return height + slope_x * x; }
  /// Nearest ground hit of a ray from above within (min_range, max_range]: range, normal
  /// (upwards, or a kerb's face towards the road), object kGround; else no hit.
  RayHit cast(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction, double min_range,
              double max_range) const;
  /// @throws std::invalid_argument naming the bad field.
  void validate() const;
};
/// The former name of GroundSurface.
using GroundPlane = GroundSurface;

/// The world at one instant: ground, scenery and actor boxes.
class SceneSnapshot
{
public:
  /// Actor boxes stand on `ground` below their centre (their base_z is set from it); scenery boxes
  /// are lowered to the lowest ground under their footprint (by nothing on the default ground).
  SceneSnapshot(const std::vector<Actor>& actors, const std::vector<SceneryBox>& scenery, double t,
                const GroundSurface& ground = GroundSurface{});

  /// Leaves every box whose bounding sphere lies entirely farther than `radius` [m] from the
  /// ground point `centre` out of cast() and actorsAlong() (a sensor there cannot see it within
  /// that range): long drives with many objects stay fast to simulate. Indices are unchanged.
  void cullBeyond(const Eigen::Vector2d& centre, double radius);

  /// Nearest hit of a ray (unit `direction`) within (min_range, max_range]. `glass_draw` decides
  /// which windows of vehicle profiles pass the ray (VehicleBody::intersect(); actor i uses the
  /// fraction of glass_draw + 0.618… · i, so that the cars along a ray differ): uniform in
  /// [0, 1) for the lidar, the default 1 (windows opaque) for the camera.
  RayHit cast(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction, double min_range,
              double max_range, double glass_draw = 1.0) const;
  /// Whether some actor has windows (a vehicle profile), i.e. cast() uses glass_draw.
  bool hasGlass() const { return has_glass_; }
  /// Every actor shape (box or profile, windows included) the ray passes through within
  /// (min_range, max_range], whether hidden or not (for the occlusion of labels). Appends actor
  /// indices to `actors`.
  void actorsAlong(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction, double min_range,
                   double max_range, std::vector<int>& actors) const;

  const std::vector<GroundBox>& actorBoxes() const { return actor_boxes_; }
  /// Whether actor i exists at the snapshot's time.
  bool actorActive(std::size_t i) const { return actor_active_[i]; }
  const std::vector<GroundBox>& sceneryBoxes() const { return scenery_boxes_; }
  const GroundSurface& ground() const { return ground_; }

private:
  /// Nearest surface of actor i along the ray (its box or its profile).
  RayHit castActor(std::size_t i, const Eigen::Vector3d& origin, const Eigen::Vector3d& direction,
                   double min_range, double glass_draw) const;

  GroundSurface ground_;
  std::vector<GroundBox> actor_boxes_;
  std::vector<int> actor_body_;  ///< per actor: index into bodies_, or −1 for a box
  std::vector<VehicleBody> bodies_;
  bool has_glass_ = false;
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
/// adding range noise and dropouts from `rng`, and where the scene has windows
/// (SceneSnapshot::hasGlass()) the glass draw of every beam. The scan is instantaneous (no
/// rolling shutter).
std::vector<LidarPoint> simulateLidarScan(const SceneSnapshot& scene, const Eigen::Isometry3d& sensor_pose,
                                          const LidarConfig& config, std::mt19937& rng);

}  // namespace grid_vision_fusion
