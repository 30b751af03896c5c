// Readers of the KITTI raw-data layout (Geiger et al., IJRR 2013): OXTS records and their
// poses, timestamps files and tracklet labels. Every reader throws std::runtime_error naming the
// file (and line or element) at fault.
#pragma once

#include <Eigen/Geometry>

#include <cstdint>
#include <iosfwd>
#include <string>
#include <vector>

namespace grid_vision_fusion
{
/// One OXTS (GPS/IMU) record, the 30 values of oxts/data/NNNNNNNNNN.txt in dataformat.txt order.
struct OxtsRecord
{
  double lat = 0.0, lon = 0.0, alt = 0.0;         ///< [deg], [deg], [m]
  double roll = 0.0, pitch = 0.0, yaw = 0.0;      ///< [rad]; yaw 0 = east, counter-clockwise
  double vn = 0.0, ve = 0.0;                      ///< velocity north / east [m/s]
  double vf = 0.0, vl = 0.0, vu = 0.0;            ///< forward / left / up velocity [m/s]
  double ax = 0.0, ay = 0.0, az = 0.0;            ///< acceleration in the vehicle frame [m/s²]
  double af = 0.0, al = 0.0, au = 0.0;            ///< forward / left / up acceleration [m/s²]
  double wx = 0.0, wy = 0.0, wz = 0.0;            ///< angular rate in the vehicle frame [rad/s]
  double wf = 0.0, wl = 0.0, wu = 0.0;            ///< angular rate forward / left / up [rad/s]
  double pos_accuracy = 0.0, vel_accuracy = 0.0;  ///< [m], [m/s]
  int navstat = 0, numsats = 0, posmode = 0, velmode = 0, orimode = 0;
};

/// Parses one OXTS line. @p source names the file in error messages.
/// @throws std::runtime_error when the line does not hold 30 numbers.
OxtsRecord parseOxtsLine(const std::string& line, const std::string& source);

/// Reads `oxts_dir`/data/0000000000.txt, 0000000001.txt... up to the first missing index.
/// @throws std::runtime_error when the folder holds no record or a record is malformed.
std::vector<OxtsRecord> readOxtsFolder(const std::string& oxts_dir);

/// Mercator scale of the first frame's latitude: cos(lat0).
double mercatorScale(double lat0_deg);

/// Pose of the IMU in the Mercator frame (x east, y north, z up) as in the KITTI devkit
/// (convertOxtsToPose): t = (s·R_e·lon·π/180, s·R_e·ln tan((90 + lat)·π/360), alt), R_e = 6378137 m,
/// rotation Rz(yaw)·Ry(pitch)·Rx(roll).
Eigen::Isometry3d oxtsToMercatorPose(const OxtsRecord& record, double scale);

/// Poses of all records relative to the first one (first pose = identity): T_0⁻¹ · T_i.
std::vector<Eigen::Isometry3d> oxtsPosesRelativeToFirst(const std::vector<OxtsRecord>& records);

/// The poses `world_from_imu` with their positions laid along their heading: the odometry frame
/// (REP 105 `odom`) that kitti_to_bag publishes and evaluate reads. Position 0 kept, position i+1 =
/// position i + ((p_{i+1} − p_i) · h) h with h the unit mean of the IMU x axes (forward) of poses i
/// and i+1; the orientations kept. A vehicle does not slip sideways, but the OXTS positions of a raw
/// drive do: on 2011_09_26 drive 0009 they run 1–2° to the right of the OXTS heading (0.1–0.4 m/s
/// sideways at 10.5 m/s, while its INS reports 0.1–0.2 m/s to the left), and everything put into the
/// world frame scan by scan drifts with them. Laid along the heading, each step keeps its length along
/// the vehicle and loses that drift; the speed, the turns and the orientations stay the OXTS ones, and
/// world ← odom, the difference of the two, is a translation.
std::vector<Eigen::Isometry3d> alongHeadingPoses(const std::vector<Eigen::Isometry3d>& world_from_imu);

/// A time stamp with nanosecond resolution (seconds since the Unix epoch, UTC).
struct KittiStamp
{
  std::int64_t sec = 0;
  std::uint32_t nsec = 0;
  double toSec() const { return static_cast<double>(sec) + 1e-9 * nsec; }
};

/// Parses "2011-09-26 13:02:25.964389445" (UTC). @throws std::runtime_error when malformed.
KittiStamp parseKittiStamp(const std::string& text, const std::string& source);

/// Reads a timestamps.txt file, one stamp per non-empty line.
/// @throws std::runtime_error naming the file and line.
std::vector<KittiStamp> readTimestamps(const std::string& path);
/// The time stamps of a timestamps.txt read from `input` (blank lines skipped); errors name
/// `source` and the line. @throws std::runtime_error as readTimestamps().
std::vector<KittiStamp> parseTimestamps(std::istream& input, const std::string& source);

/// One pose of a tracklet: bottom centre of the 3-D box in the velodyne frame of frame
/// first_frame + index, yaw rz around z.
struct TrackletPose
{
  double tx = 0.0, ty = 0.0, tz = 0.0;  ///< [m]
  double rx = 0.0, ry = 0.0, rz = 0.0;  ///< [rad]
  int state = 0;                        ///< 0 unset, 1 interpolated, 2 labelled
  int occlusion = 0;                    ///< 0 visible, 1 partly, 2 fully occluded, −1 unknown
  int truncation = 0;                   ///< 0 in image, 1 truncated, 2 out of image, 99 unknown
};

/// One labelled object of a raw drive (tracklet_labels.xml).
struct Tracklet
{
  std::string object_type;           ///< "Car", "Van", "Truck", "Pedestrian", "Cyclist", "Tram", ...
  double h = 0.0, w = 0.0, l = 0.0;  ///< box height, width, length [m]
  int first_frame = 0;
  std::vector<TrackletPose> poses;  ///< pose j belongs to frame first_frame + j

  /// Whether the tracklet has a pose in `frame`.
  bool inFrame(int frame) const
  {
    return frame >= first_frame && frame < first_frame + static_cast<int>(poses.size());
  }
};

/// Reads a tracklet_labels.xml (Boost serialization XML of the KITTI raw data).
/// @throws std::runtime_error naming the file and what is missing or malformed.
std::vector<Tracklet> readTracklets(const std::string& path);
/// The tracklets of a tracklet_labels.xml read from `input`; errors name `source`.
/// @throws std::runtime_error as readTracklets().
std::vector<Tracklet> parseTracklets(std::istream& input, const std::string& source);

}  // namespace grid_vision_fusion
