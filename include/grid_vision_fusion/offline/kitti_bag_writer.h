// Conversion of a KITTI raw synced drive (Geiger et al., IJRR 2013) into a ROS bag with the topic
// and frame names of kitti2bag, but with the camera model of the rectified `_sync` images: each
// camera frame is the optical centre of rectified camera i (axes of the rectified camera-0 frame,
// R_rect_00 · Tr_velo_to_cam, shifted by K_i⁻¹ times the 4th column of P_rect_0i) and its camera_info
// carries P = [K_i | 0] (D = 0, R = I, size S_rect_0i), so that image_geometry::PinholeCameraModel
// projects lidar points transformed by tf exactly as P_rect_0i · R_rect_00 · Tr_velo_to_cam does.
#pragma once

#include "grid_vision_fusion/kitti/kitti_calibration.h"
#include "grid_vision_fusion/kitti/kitti_raw.h"

#include <geometry_msgs/TransformStamped.h>
#include <geometry_msgs/TwistStamped.h>
#include <ros/time.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>
#include <sensor_msgs/Imu.h>
#include <sensor_msgs/NavSatFix.h>
#include <sensor_msgs/PointCloud2.h>

#include <Eigen/Geometry>

#include <cstddef>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

namespace grid_vision_fusion
{
/// Topic and frame names of one KITTI camera in kitti2bag's layout.
struct KittiCameraNames
{
  std::string name;         ///< "camera_color_left", ... (also the frame id)
  std::string image_topic;  ///< "/kitti/<name>/image_raw"
  std::string info_topic;   ///< "/kitti/<name>/camera_info"
  std::string folder;       ///< "image_0<i>" in the drive folder
  std::string encoding;     ///< "mono8" (cameras 0, 1) or "rgb8" (cameras 2, 3)
};

/// Names of KITTI camera `camera` (0 grey left, 1 grey right, 2 colour left, 3 colour right).
/// @throws std::out_of_range for a camera outside 0..3.
KittiCameraNames kittiCameraNames(int camera);

/// Options of one conversion.
struct KittiBagOptions
{
  /// The synced drive folder, e.g. ".../2011_09_26/2011_09_26_drive_0001_sync".
  std::string drive_dir;
  /// Folder of calib_cam_to_cam.txt, calib_velo_to_cam.txt, calib_imu_to_velo.txt; empty: the
  /// parent folder of drive_dir (the KITTI layout).
  std::string calibration_dir;
  /// The bag to write. Written as `<output_bag>.tmp` and renamed on success.
  std::string output_bag;
  /// First frame (drive index) to convert; its OXTS pose is the origin of `world`.
  int first_frame = 0;
  /// Last frame, inclusive; negative: the last frame of the drive (number of velodyne scans − 1).
  int last_frame = -1;
  /// KITTI camera indices to include (0, 1 grey; 2, 3 colour); each at most once.
  std::vector<int> cameras{2};
  /// Bag compression: "none", "bz2" or "lz4".
  std::string compression = "none";
  /// Called after each written frame with (frames done, frames in total); may be empty.
  std::function<void(std::size_t, std::size_t)> progress;

  /// The calibration folder actually used (calibration_dir, or the parent of drive_dir).
  std::string calibrationDirectory() const;
  /// @throws std::invalid_argument naming the field when an option is invalid.
  void validate() const;
};

/// What a conversion wrote.
struct KittiBagSummary
{
  std::size_t frames = 0;    ///< frames converted
  std::size_t messages = 0;  ///< messages written, all topics together
  std::string output_bag;    ///< the bag written
};

/// Converts the frames [first_frame, last_frame] of a KITTI raw synced drive into a bag.
/// Topics (kitti2bag names): /kitti/velo/pointcloud, /kitti/<camera>/image_raw and camera_info,
/// /kitti/oxts/imu, /kitti/oxts/gps/fix, /kitti/oxts/gps/vel, /tf (world → odom → base_link, one
/// message per frame at the OXTS stamp: odom ← base_link the OXTS pose laid along its heading,
/// alongHeadingPoses(), and world ← odom the rest of the OXTS pose), /tf_static (one latched message at the
/// first stamp: base_link → imu_link → velo_link → camera frames). A KITTI raw drive's first scan and images
/// are stamped before its first OXTS record (13 ms on drive 0001): the first pose is also written at the
/// first frame's earliest sensor stamp, moved back along the record's velocity and angular
/// rate (poseBefore()), when that is at most kMaxPoseExtrapolationS earlier, so that the first
/// frame has a pose. The bag is written to `<output_bag>.tmp` and renamed
/// only when every frame was converted; on any error the temporary file is removed.
/// @throws std::invalid_argument for invalid options; std::runtime_error naming the file at fault
/// (missing calibration key, missing frame file, truncated .bin, short timestamps file,
/// unreadable image or image size different from S_rect) or the bag that cannot be written.
KittiBagSummary convertKittiDrive(const KittiBagOptions& options);

// -- The message builders used by convertKittiDrive, public for tests and other tools. --

/// The longest time by which the first frame's sensors may precede its first OXTS record and
/// still get a pose [s]: half a frame at 10 Hz. KITTI's raw drives lead by about 13 ms; a
/// longer lead is a broken drive, whose first frame is left without a pose.
constexpr double kMaxPoseExtrapolationS = 0.05;

/// The pose `dt` seconds before `pose` [s], moved back along the OXTS record's body velocity
/// (forward, left, up) and angular rate (about forward, left, up), assumed constant over `dt`.
Eigen::Isometry3d poseBefore(const Eigen::Isometry3d& pose, const OxtsRecord& record, double dt);

/// ros::Time of a KITTI stamp. @throws std::runtime_error when it is outside ros::Time's range.
ros::Time toRosTime(const KittiStamp& stamp);

/// A transform message parent → child holding `parent_from_child` (the child frame's pose in
/// the parent frame, tf's convention).
geometry_msgs::TransformStamped toTransformMsg(const Eigen::Isometry3d& parent_from_child,
                                               const std::string& parent, const std::string& child,
                                               const ros::Time& stamp);

/// Optical centre of rectified camera `camera` in the rectified camera-0 frame [m]:
/// t_i with P_rect_0i = K_i · [I | t_i] (for camera 2 of 2011_09_26: (0.0599, −0.0004, 0.0027)).
/// @throws std::runtime_error when P_rect_0i is not of that form (last row (0, 0, 1, t), focal
/// lengths > 0); std::out_of_range for a camera outside 0..3.
Eigen::Vector3d kittiCameraCentre(const KittiRawCalibration& calibration, int camera);

/// The frame of `camera` (rectified camera-0 axes, origin at the camera's optical centre) ←
/// velodyne: Translation(t_i) · R_rect_00 · Tr_velo_to_cam. With it, K_i · (camera ← velo) ·
/// X = P_rect_0i · R_rect_00 · Tr_velo_to_cam · X for every velodyne point X.
/// @throws as kittiCameraCentre().
Eigen::Isometry3d kittiCameraFromVelo(const KittiRawCalibration& calibration, int camera);

/// The static transforms: base_link → imu_link (identity), imu_link → velo_link
/// (Tr_imu_to_velo⁻¹), velo_link → each camera frame (kittiCameraFromVelo()⁻¹).
/// @throws as kittiCameraCentre().
std::vector<geometry_msgs::TransformStamped> kittiStaticTransforms(const KittiRawCalibration& calibration,
                                                                   const std::vector<int>& cameras,
                                                                   const ros::Time& stamp);

/// Camera info of the rectified image of `camera` in its frame of kittiCameraFromVelo():
/// K = left 3×3 of P_rect_0i, P = [K | 0] (ROS wants P(2,3) = 0: image_geometry asserts it), R = I,
/// D = 5 zeros (plumb_bob), size S_rect_0i. @throws as kittiCameraCentre().
sensor_msgs::CameraInfo kittiCameraInfo(const KittiRawCalibration& calibration, int camera,
                                        const ros::Time& stamp);

/// Reads a velodyne scan (float32 x, y, z, reflectance per point) into a PointCloud2 with fields
/// x, y, z, intensity (float32) in `velo_link`.
/// @throws std::runtime_error naming the file when it is missing, unreadable or its size is not a
/// multiple of 16 bytes.
sensor_msgs::PointCloud2 readVelodyneScan(const std::string& path, const ros::Time& stamp);

/// Reads a PNG image of `camera` (rgb8 for colour cameras, mono8 for grey ones).
/// @throws std::runtime_error naming the file when it is missing or cannot be decoded, or when its
/// size differs from S_rect_0i (`expected_width` × `expected_height`).
sensor_msgs::Image readKittiImage(const std::string& path, int camera, std::uint32_t expected_width,
                                  std::uint32_t expected_height, const ros::Time& stamp);

/// IMU message of an OXTS record in imu_link: orientation from roll, pitch, yaw (Rz·Ry·Rx, ENU),
/// angular velocity (wx, wy, wz) [rad/s] and linear acceleration (ax, ay, az) [m/s², gravity
/// included] in the vehicle body frame (x front, y left, z top), as kitti2bag. Not wf/wl/wu,
/// af/al/au: those are about the level frame (rotated by the heading only), not about imu_link.
/// Covariances unknown (zeros).
sensor_msgs::Imu oxtsToImu(const OxtsRecord& record, const ros::Time& stamp);

/// GPS fix of an OXTS record in imu_link: latitude, longitude [deg], altitude [m]; position
/// covariance approximated as diag(pos_accuracy²).
sensor_msgs::NavSatFix oxtsToNavSatFix(const OxtsRecord& record, const ros::Time& stamp);

/// Velocity of an OXTS record in imu_link (kitti2bag's /kitti/oxts/gps/vel): linear (vf, vl, vu)
/// [m/s], angular (wf, wl, wu) [rad/s].
geometry_msgs::TwistStamped oxtsToTwist(const OxtsRecord& record, const ros::Time& stamp);

}  // namespace grid_vision_fusion
