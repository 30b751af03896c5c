// A synthetic drive scenario: the ego trajectory, the actors with their trajectories, the
// scenery and the sensors' settings, read from a YAML file (see config/synthetic_drive.yaml).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "grid_vision_fusion/simulation/synthetic_camera.h"
#include "grid_vision_fusion/simulation/synthetic_world.h"

namespace grid_vision_fusion
{
/// The error of an INS's pose estimate that the drive's OXTS records carry (the sensors see the
/// true pose): all zero by default (the records are exact). Seeded from the scenario's seed
/// (its own random stream: the scans and images do not change with it).
struct InsError
{
  double position_std = 0.0;  ///< horizontal position error, std per axis (east, north) [m] (>= 0)
  /// Correlation time of the position error [s] (>= 0): a first-order Gauss-Markov process of
  /// stationary std position_std; 0: independent from record to record.
  double position_correlation_s = 0.0;
  double height_std = 0.0;      ///< altitude error per record, std [m] (>= 0)
  double yaw_drift_rate = 0.0;  ///< constant heading drift [rad/s] (0.8° over 5 s: 0.0028)
  double yaw_walk_std = 0.0;    ///< heading random walk [rad/√s] (>= 0)
  double roll_std = 0.0;        ///< roll error per record, std [rad] (>= 0)
  double pitch_std = 0.0;       ///< pitch error per record, std [rad] (>= 0)

  /// Whether any error is set.
  bool enabled() const;
  /// @throws std::invalid_argument naming the bad field.
  void validate() const;
};

/// The vehicle profile that `vehicle_shape: car` gives an actor of this KITTI type: kCar for
/// "Car", kVan for "Van", kBox otherwise (trucks and buses are box-shaped enough).
VehicleShape profileForType(const std::string& type);

/// Everything a synthetic drive needs.
struct SyntheticScenario
{
  std::uint32_t seed = 42;      ///< seeds the lidar noise and dropouts
  double duration_s = 10.0;     ///< length of the drive [s], > 0
  double frame_rate_hz = 10.0;  ///< frames per second (KITTI: 10), > 0
  /// Each frame's OXTS record is sampled and stamped this much after its scan and image [s],
  /// [0, half a frame): KITTI's raw drives record it about 13 ms later (their first scan has no
  /// earlier pose).
  double oxts_delay_s = 0.0;
  Trajectory ego = Trajectory::parked({});  ///< ego vehicle (IMU / base_link) ground pose over time
  std::vector<Actor> actors;
  std::vector<SceneryBox> scenery;
  RoadStyle road;
  /// The ground: flat by default; its center_y and half_width are the road's.
  GroundSurface ground;
  /// Actors whose shape is not given take profileForType() of their type (else a box);
  /// recordedDriveScenario() applies it to the recorded tracklets too.
  bool vehicle_profiles = false;
  double glass_transmission = 0.5;  ///< share of lidar beams a window lets through, [0, 1]
  InsError ins_error;               ///< of the OXTS records
  LidarConfig lidar;

  /// Number of frames: round(duration · rate).
  int frameCount() const;
  /// Time of frame i from the start [s].
  double frameTime(int frame) const { return frame / frame_rate_hz; }
  /// @throws std::invalid_argument naming the bad field.
  void validate() const;
};

/// Reads a scenario YAML file. Keys: seed, duration, frame_rate, oxts_delay, road {center_y, half_width,
/// lane_width}, ground {slope, camber, kerb_height, verge_rise_left, verge_rise_right,
/// verge_width}, vehicle_shape (box | car), glass_transmission, ins_error {position_std,
/// position_correlation, height_std, yaw_drift_rate, yaw_walk_std, roll_std, pitch_std},
/// lidar {azimuth_steps, range_noise_std, dropout, min_range, max_range}, ego and
/// every entry of actors with one motion: `parked: {x, y, yaw}`, `waypoints: [[t, x, y], ...]`
/// (yaw along the path, Trajectory::waypoints()), `waypoints: [[t, x, y, yaw], ...]` (yaw given
/// in every waypoint, e.g. reversing; Trajectory::posed()) or
/// `constant_turn: {x, y, yaw, speed, yaw_rate}`; actors also have type, size [l, w, h],
/// color "#RRGGBB" and optionally shape (box | car | van); scenery entries have x, y, yaw, size,
/// color. Unknown keys in ground and ins_error are errors.
/// @throws std::runtime_error naming the file and the entry at fault.
SyntheticScenario loadScenario(const std::string& path);
/// loadScenario() of the YAML text `yaml`; errors name `source`.
SyntheticScenario parseScenario(const std::string& yaml, const std::string& source);

/// Parses "#RRGGBB" or "RRGGBB". @throws std::invalid_argument when malformed.
std::uint32_t parseColor(const std::string& text);

}  // namespace grid_vision_fusion
