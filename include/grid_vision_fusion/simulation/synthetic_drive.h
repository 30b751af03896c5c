// Writes a synthetic scenario as a KITTI raw drive: the calibration files of the recording day,
// image_02 (PNG, rendered), velodyne_points (.bin, ray cast), oxts, timestamps,
// tracklet_labels.xml, plus per-frame KITTI object labels (label_2) of the rendered boxes.
// The sensors sit where they sit on the KITTI vehicle (the day's calibration), so every tool that
// reads KITTI raw data reads a synthetic drive unchanged, and the ground truth is exact.
#pragma once

#include <Eigen/Geometry>

#include <functional>
#include <string>
#include <vector>

#include "grid_vision_fusion/kitti/kitti_calibration.h"
#include "grid_vision_fusion/simulation/synthetic_scenario.h"

namespace grid_vision_fusion
{
/// Where and how a synthetic drive is written.
struct SyntheticDriveOptions
{
  std::string output_root;          ///< the drive goes to <root>/<date>/<date>_drive_<NNNN>_sync
  std::string calibration_dir;      ///< folder with calib_cam_to_cam/velo_to_cam/imu_to_velo.txt
  std::string date = "2011_09_26";  ///< recording day: folder names and first time stamp
  int drive_number = 9001;          ///< synthetic drives count from 9001, real ones stay below
  int max_frames = -1;              ///< write only the first N frames (< 0: all)
  std::string start_time = "2011-09-26 13:00:00.000000000";  ///< stamp of frame 0 (UTC)
  double origin_lat_deg = 49.011;  ///< world origin for the OXTS records (Karlsruhe)
  double origin_lon_deg = 8.4237;
  double origin_alt_m = 116.0;
  double lidar_height_m = 1.73;  ///< height of the velodyne above the road (KITTI)

  /// @throws std::invalid_argument naming the bad field.
  void validate() const;
};

/// What writeSyntheticDrive() produced.
struct SyntheticDriveSummary
{
  std::string drive_dir;  ///< the *_sync folder
  int frames = 0;
  std::size_t lidar_points = 0;  ///< over all scans
  std::size_t labels = 0;        ///< label_2 lines over all frames
};

/// One OXTS record's error: what the INS reports minus the truth.
struct InsErrorSample
{
  double east = 0.0;   ///< [m]
  double north = 0.0;  ///< [m]
  double up = 0.0;     ///< [m]
  double yaw = 0.0;    ///< [rad]
  double roll = 0.0;   ///< [rad]
  double pitch = 0.0;  ///< [rad]
};

/// The INS errors of the records at `times` [s] (increasing, from the drive's start) under
/// `model`: a position error per axis (first-order Gauss-Markov, or independent per record), a
/// heading error yaw_drift_rate · t plus a random walk that starts at 0, independent height, roll
/// and pitch errors. Deterministic for `seed`; all zero when the model is disabled.
std::vector<InsErrorSample> sampleInsErrors(const InsError& model, std::uint32_t seed,
                                            const std::vector<double>& times);

/// The true pose of the ego's IMU (KITTI's base frame) at ground pose `pose`, `imu_height` [m]
/// above the ground: on flat ground (no profile, no slope, height 0) the pose turned by its yaw
/// only, as drives always had; else standing on the ground under its four wheels (2.7 m
/// wheelbase, 1.6 m track, centred on the ground pose): their mean height, and the roll (left
/// side up positive) and pitch (front down positive) of the plane through them, rotation
/// Rz(yaw) · Ry(pitch) · Rx(roll) as the OXTS's.
Eigen::Isometry3d egoImuPose(const GroundSurface& ground, const Pose2D& pose, double imu_height);

/// A scenario that replays a recorded KITTI raw drive (its oxts/ and tracklet_labels.xml): the
/// ego follows the OXTS poses relative to the first frame, flattened onto the ground plane (x, y,
/// yaw); every tracklet becomes an actor of its type and size that follows its recorded poses
/// while it is labelled and is absent otherwise. Frame i is at t = i / base.frame_rate_hz. Road,
/// ground, scenery, vehicle profiles, INS error, lidar settings, seed and frame rate come from
/// `base`; the duration covers the recorded frames. @throws std::runtime_error naming the file at fault.
SyntheticScenario recordedDriveScenario(const std::string& drive_dir, const KittiRawCalibration& calibration,
                                        const SyntheticScenario& base);

/// The standard 30-line OXTS dataformat.txt of the KITTI raw data.
std::string oxtsDataFormat();

/// Writes the drive. `progress(done, total)` is called after every frame.
/// @throws std::runtime_error naming a file that cannot be read or written.
SyntheticDriveSummary writeSyntheticDrive(const SyntheticScenario& scenario,
                                          const SyntheticDriveOptions& options,
                                          const std::function<void(int, int)>& progress = nullptr);

}  // namespace grid_vision_fusion
