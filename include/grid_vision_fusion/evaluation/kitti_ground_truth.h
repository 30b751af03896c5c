// Ground truth for the evaluation from a KITTI raw drive (Geiger et al., IJRR 2013): 2-D boxes in
// image 2 from the tracklets' 3-D boxes, motion state from the objects' speed over ground, 3-D
// position and velocity in the world frame. Also from the labels of the KITTI tracking benchmark
// (one file per sequence, label_02/NNNN.txt, a sequence being a raw drive frame for frame): the
// labelled boxes, the track ids as identities, the velocity fitted over at least a second of each
// track's world positions. And a reader of per-frame label files in the KITTI object format with
// a motion column, for data labelled elsewhere (e.g. KITTI MOD).
//
// Frames:
// - velodyne frame of frame i: where the tracklet poses of frame i live (x forward, y left, z up);
// - world frame: the IMU frame of the first OXTS record (oxtsPosesRelativeToFirst()), i.e. the
//   `world` frame of bags made by kitti_to_bag / kitti2bag; world ← velo_i = world_from_imu_i ·
//   velo_from_imu⁻¹.
// Frame names: the 10-digit index of the raw layout ("0000000042", as image_02/data/0000000042.png).
#pragma once

#include <Eigen/Geometry>

#include <map>
#include <string>
#include <vector>

#include "grid_vision_fusion/detection/kitti_labels.h"
#include "grid_vision_fusion/evaluation/evaluation.h"
#include "grid_vision_fusion/kitti/kitti_calibration.h"
#include "grid_vision_fusion/kitti/kitti_raw.h"

namespace grid_vision_fusion
{
/// The frame name of frame `index` (≥ 0): 10 digits, zero padded ("0000000042").
std::string kittiFrameName(int index);

/// Parameters of the ground truth.
struct KittiGroundTruthConfig
{
  int camera = 2;  ///< camera whose rectified image holds the boxes, 0..3
  /// Objects moving faster than this over ground (horizontal world speed) are dynamic [m/s], ≥ 0.
  double dynamic_speed_mps = 0.5;
  /// Tracklets: velocity by differences over ±speed_half_window frames (one-sided at the ends)
  /// [frames], ≥ 1.
  int speed_half_window = 2;
  /// Tracking labels: velocity by a least-squares line through the track's positions (the ego's
  /// path laid along its heading, alongHeadingPoses()) over at least this span, centred where the
  /// track allows (fittedVelocity()); a track whose positions span less has no speed (motion
  /// unknown, difficult) [s], > 0.
  double speed_window_s = 1.0;
  /// A box whose truncation (1 − clipped area / projected area) exceeds this is difficult, [0, 1].
  double max_truncation = 0.5;
  /// A tracklet pose with this occlusion flag or more (2 = heavily occluded) is difficult; labels:
  /// KITTI `occluded` ≥ this. 0..3.
  int difficult_occlusion = 2;
  /// A tracklet pose with this truncation flag (2 = out of image) is difficult (99 = unknown is
  /// not); tracking labels: truncation level ≥ this (2 = heavily truncated). ≥ 1.
  int difficult_truncation_flag = 2;
  /// 3-D box edges are clipped against this depth in front of the camera before projecting [m], > 0.
  double near_plane_m = 0.1;
  /// Class renaming applied to the lower-cased object type ("car", "van", "tram"...): a type
  /// mapped to "" is dropped; a type not listed is kept as is when keep_unmapped, else dropped.
  std::map<std::string, std::string> class_map;
  bool keep_unmapped = true;

  /// @throws std::invalid_argument naming the bad field.
  void validate() const;
  /// The evaluation label of a KITTI object type (lower-cased, then mapped); "" = drop it.
  std::string labelOf(const std::string& object_type) const;
};

/// The metadata of one raw drive that the evaluation needs.
struct KittiDrive
{
  std::vector<KittiStamp> stamps;                 ///< image_02/timestamps.txt, one per frame
  std::vector<Eigen::Isometry3d> world_from_imu;  ///< OXTS poses relative to the first frame
  /// The same in the odometry frame that kitti_to_bag publishes as `odom`: laid along their
  /// heading (alongHeadingPoses()).
  std::vector<Eigen::Isometry3d> odom_from_imu;
  KittiRawCalibration calibration;
  std::vector<Tracklet> tracklets;  ///< empty when not read

  /// Reads `drive_dir`/image_02/timestamps.txt, `drive_dir`/oxts/data/*.txt, the calibration of
  /// `calibration_dir` (empty: the parent folder of drive_dir) and, when `with_tracklets`,
  /// `drive_dir`/tracklet_labels.xml.
  /// @throws std::runtime_error naming the file at fault, or when the numbers of timestamps and
  /// OXTS records differ.
  static KittiDrive read(const std::string& drive_dir, const std::string& calibration_dir,
                         bool with_tracklets);

  int frameCount() const { return static_cast<int>(stamps.size()); }
  /// world ← velodyne of frame `frame`. @throws std::out_of_range for a frame outside the drive.
  Eigen::Isometry3d worldFromVelo(int frame) const;
  /// world ← odom at frame `frame` (a translation: the GPS position less the dead-reckoned one).
  /// @throws std::out_of_range for a frame outside the drive.
  Eigen::Isometry3d worldFromOdom(int frame) const;
  /// Frame times in seconds (KittiStamp::toSec()).
  std::vector<double> frameTimes() const;
};

/// One ground-truth object with what the evaluation does not carry.
struct GroundTruthObject
{
  EvalObject object;  ///< as handed to evaluate(); frame = kittiFrameName(frame_index)
  int frame_index = 0;
  /// Index in the tracklet list; the track_id of tracking labels; −1 for label files and
  /// DontCare regions.
  int tracklet = -1;
  double truncation = 0.0;  ///< of the projected box, [0, 1]
  double speed_mps = 0.0;   ///< horizontal world speed (tracklets and tracking labels)
  Eigen::Vector3d velo_center = Eigen::Vector3d::Zero();  ///< box centre, velodyne frame [m]
};

/// The 2-D box of a 3-D box in the rectified image of `camera`: the 8 corners (bottom centre
/// `bottom_center_velo`, yaw `yaw` around z, length along x, width along y, height up, in the
/// velodyne frame) projected with P_rect_0c · R_rect_00 · Tr_velo_to_cam, edges clipped against
/// the near plane first, then the box clipped to [0, W−1] × [0, H−1]. Returns false when nothing
/// of the box is in front of the camera and inside the image.
bool projectVeloBox(const KittiRawCalibration& calibration, int camera,
                    const Eigen::Vector3d& bottom_center_velo, double yaw, double length, double width,
                    double height, double near_plane_m, BoundingBox& box, double& truncation);

/// Velocity at sample `j` of a trajectory from differences over ±half_window samples (one-sided
/// at the ends): (p[hi] − p[lo]) / (t[hi] − t[lo]). Zero when the trajectory has one sample.
/// @throws std::invalid_argument when sizes differ or the times do not increase.
Eigen::Vector3d trajectoryVelocity(const std::vector<Eigen::Vector3d>& positions,
                                   const std::vector<double>& times, std::size_t j, int half_window);

/// Velocity at sample `j` of a trajectory: the slope of the least-squares line through the
/// positions of samples lo..hi against their times, where lo..hi grows from j one sample at a
/// time, on the side whose next sample is nearer in time to sample j (the lower on a tie), until
/// times[hi] − times[lo] ≥ window_s or the whole trajectory is used: centred inside the
/// trajectory, one-sided at its ends. Zero when the trajectory has one sample.
/// @throws std::invalid_argument when sizes differ, j is out of range, window_s is not > 0 or
/// the times do not increase.
Eigen::Vector3d fittedVelocity(const std::vector<Eigen::Vector3d>& positions,
                               const std::vector<double>& times, std::size_t j, double window_s);

/// Ground truth of every tracklet pose of `drive` (see the file comment and the config). A
/// tracklet with a single pose has no velocity: motion unknown and difficult. Boxes that do not
/// project into the image are left out.
/// @throws std::runtime_error when a tracklet has poses beyond the drive's frames.
std::vector<GroundTruthObject> trackletGroundTruth(const KittiDrive& drive,
                                                   const KittiGroundTruthConfig& config);

/// One line of a label file with a motion column.
struct MotionLabel
{
  KittiObjectLabel label;
  Motion motion = Motion::kUnknown;
};

/// Parses a label file in the KITTI object format plus a motion column: per object one line
/// of the 15 KITTI columns (type truncated occluded alpha left top right bottom h w l x y z ry),
/// an optional score, then a final token `static` or `dynamic` (16 or 17 tokens). Blank lines
/// are skipped. @throws KittiLabelError "<source>:<line>: <what>" for a malformed line.
std::vector<MotionLabel> parseMotionLabels(std::istream& input, const std::string& source_name);
/// Reads a label file with a motion column. @throws KittiLabelError naming the file (and line).
std::vector<MotionLabel> readMotionLabels(const std::string& path);

/// Ground truth from a folder of label files `<index>.txt` (any number of digits, e.g.
/// 000042.txt or 0000000042.txt) with a motion column. DontCare objects are dropped; boxes are
/// clipped to the image of `camera`; difficult as for tracklets (`truncated` > max_truncation or
/// `occluded` ≥ difficult_occlusion); longitudinal distance = x of the box centre in the
/// velodyne frame (labels give the bottom centre in the rectified camera-0 frame). No position
/// or velocity (has_state = false): label files carry no velocity.
/// @throws std::runtime_error (KittiLabelError) naming the folder or file at fault.
std::vector<GroundTruthObject> labelFolderGroundTruth(const std::string& label_dir,
                                                      const KittiRawCalibration& calibration,
                                                      const KittiGroundTruthConfig& config);

/// One line of a KITTI tracking benchmark label file (label_02/NNNN.txt):
///   frame track_id type truncated occluded alpha left top right bottom h w l x y z rotation_y [score]
/// (Geiger et al., devkit of the tracking benchmark; 3-D values in the rectified camera-0 frame).
struct TrackingLabel
{
  int frame = 0;      ///< frame index in the sequence (= in the raw drive), ≥ 0
  int track_id = -1;  ///< the object's identity over the sequence, ≥ 0; −1 for DontCare
  /// The other columns in the object format; `truncated` holds the tracking benchmark's
  /// truncation level 0 (not), 1 (partly), 2 (heavily truncated), `occluded` 0 (visible),
  /// 1 (partly), 2 (largely occluded), 3 (unknown); both −1 for DontCare.
  KittiObjectLabel object;
  std::size_t line = 0;  ///< 1-based line in the file
  bool dontCare() const { return lowerCase(object.type) == "dontcare"; }
};

/// Parses a tracking label file: 17 fields per line, or 18 with a score; blank lines skipped.
/// @throws KittiLabelError "<source_name>:<line>: <what>" for a line with another number of
/// fields, a frame that is not an integer ≥ 0, an object (any type but DontCare) whose track_id
/// is not an integer ≥ 0, whose truncation level is not 0, 1 or 2, whose occlusion level is not
/// 0..3 or whose dimensions are not > 0, a number that is not finite, a box with right < left or
/// bottom < top, or a track_id that appears twice in one frame.
std::vector<TrackingLabel> parseTrackingLabels(std::istream& input, const std::string& source_name);
/// Reads a tracking label file. @throws KittiLabelError naming the file (and line).
std::vector<TrackingLabel> readTrackingLabels(const std::string& path);

/// Ground truth from tracking labels, with what was left out of them.
struct TrackingGroundTruth
{
  /// The objects and the DontCare regions (object.dont_care), in frame order.
  std::vector<GroundTruthObject> objects;
  std::size_t dont_care = 0;  ///< DontCare regions among them
  /// Labels of frames the drive does not have (≥ frameCount()), left out: how many, the
  /// smallest and largest such frame, the line of the first such label (in the list's order).
  std::size_t beyond_drive = 0;
  int first_frame_beyond = -1;
  int last_frame_beyond = -1;
  std::size_t first_line_beyond = 0;
};

/// Ground truth of `labels` on `drive` (its time stamps, OXTS poses and calibration). Per object
/// line: the labelled box clipped to the image of `camera`; the label (labelOf(), dropped when
/// empty); identity (object.track_id, tracklet) = track_id; the box centre (x, y − h/2, z) in
/// the rectified camera-0 frame → velodyne → world through the frame's OXTS pose (position,
/// longitudinal distance = its velodyne x); velocity fittedVelocity() with `speed_window_s` over
/// the track's positions through the poses alongHeadingPoses() (in world axes), speed over
/// ground |(v_x, v_y)|, dynamic above `dynamic_speed_mps`; a track spanning less than
/// `speed_window_s` has motion unknown and is difficult. Difficult as tracklets: the 3-D box projected
/// (projectVeloBox()) is truncated by more than `max_truncation`, or truncation level ≥
/// `difficult_truncation_flag`, or occlusion level ≥ `difficult_occlusion`. DontCare lines become DontCare
/// regions (box clipped).
TrackingGroundTruth trackingLabelGroundTruth(const std::vector<TrackingLabel>& labels,
                                             const KittiDrive& drive, const KittiGroundTruthConfig& config);

/// The index of the frame whose time is nearest to `t` (times sorted ascending), or −1 when
/// none lies within `tolerance_s`.
int nearestFrame(const std::vector<double>& frame_times, double t, double tolerance_s);

/// The EvalObjects of a ground-truth list.
std::vector<EvalObject> evalObjects(const std::vector<GroundTruthObject>& ground_truth);

}  // namespace grid_vision_fusion
