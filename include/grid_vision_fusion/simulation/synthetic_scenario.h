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
  LidarConfig lidar;

  /// Number of frames: round(duration · rate).
  int frameCount() const;
  /// Time of frame i from the start [s].
  double frameTime(int frame) const { return frame / frame_rate_hz; }
  /// @throws std::invalid_argument naming the bad field.
  void validate() const;
};

/// Reads a scenario YAML file. Keys: seed, duration, frame_rate, oxts_delay, road {center_y, half_width,
/// lane_width}, lidar {azimuth_steps, range_noise_std, dropout, min_range, max_range}, ego and
/// every entry of actors with one motion: `parked: {x, y, yaw}`, `waypoints: [[t, x, y], ...]`
/// (yaw along the path, Trajectory::waypoints()), `waypoints: [[t, x, y, yaw], ...]` (yaw given
/// in every waypoint, e.g. reversing; Trajectory::posed()) or
/// `constant_turn: {x, y, yaw, speed, yaw_rate}`; actors also have type, size [l, w, h] and
/// color "#RRGGBB"; scenery entries have x, y, yaw, size, color.
/// @throws std::runtime_error naming the file and the entry at fault.
SyntheticScenario loadScenario(const std::string& path);
/// loadScenario() of the YAML text `yaml`; errors name `source`.
SyntheticScenario parseScenario(const std::string& yaml, const std::string& source);

/// Parses "#RRGGBB" or "RRGGBB". @throws std::invalid_argument when malformed.
std::uint32_t parseColor(const std::string& text);

}  // namespace grid_vision_fusion
