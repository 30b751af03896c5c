// Fusion regions and point-wise feature processing (Gómez et al., §III-C and §III-D).
#pragma once

#include <cstddef>
#include <cstdint>
#include <limits>
#include <map>
#include <string>
#include <vector>

#include "grid_vision_fusion/fusion/motion_model.h"
#include "grid_vision_fusion/fusion/object_centre.h"
#include "grid_vision_fusion/types.h"

namespace grid_vision_fusion
{
/// What motion a fusion region gets when it holds as many static as dynamic points.
enum class TieRule
{
  kStatic,   ///< report static (the paper's choice is silent; a tie is no evidence of motion)
  kDynamic,  ///< report dynamic (the cautious choice for planning)
  kUnknown,  ///< report MOTION_UNKNOWN
};

/// Parses "static", "dynamic" or "unknown". @throws std::invalid_argument otherwise.
TieRule tieRuleFromString(const std::string& name);
/// The name parsed by tieRuleFromString().
std::string toString(TieRule rule);

/// Which point of a fusion region is reported as the object's position.
enum class PositionSource
{
  kCentre,  ///< the object's centre: estimateCentres()
  kMedian,  ///< the paper's component-wise median of the region's cells (its near face)
};

/// Parses "centre" or "median". @throws std::invalid_argument otherwise.
PositionSource positionSourceFromString(const std::string& name);
/// The name parsed by positionSourceFromString().
std::string toString(PositionSource source);

/// What an object's position and motion rest on in an image.
enum class ObjectSupport : std::uint8_t
{
  kCells = 0,  ///< grid cells in its fusion band: motion and position from them (and its track)
  kTrack = 1,  ///< no cell in its band (or its box lies beyond the grid): its track's prediction
  kBox = 2,    ///< no cell and no track that knows where it is: its box's bottom on the ground
};

/// Which cells of a fusion region vote for its motion.
enum class MotionVote
{
  kRegion,   ///< every cell of the region (the paper's point-wise cardinality)
  kCluster,  ///< the cells of the object's own cluster only: objectCluster() of the region
};

/// Parses "region" or "cluster". @throws std::invalid_argument otherwise.
MotionVote motionVoteFromString(const std::string& name);
/// The name parsed by motionVoteFromString().
std::string toString(MotionVote vote);

/// Parameters of the fusion region and of the point-wise feature processing.
struct FusionConfig
{
  /// a: the band reaches a·h above the box bottom edge (h = box height) [fraction of h].
  /// The paper's Y_low = (3·y_max + y_min)/4 is a = 0.25.
  double band_above = 0.25;
  /// b: the band reaches b·h below the box bottom edge [fraction of h].
  /// The paper's Y_high = (5·y_max − y_min)/4 is b = 0.25.
  double band_below = 0.25;
  /// A region needs at least this many points of the winning state for a STATIC or DYNAMIC
  /// verdict; with fewer it is reported MOTION_UNKNOWN (position still given). Range >= 1.
  int min_points = 1;
  /// Motion of a region with equal static and dynamic cardinalities.
  TieRule tie_rule = TieRule::kStatic;
  /// When true, a point inside several fusion regions counts only for the region of the box
  /// whose bottom edge is lowest in the image (largest y_max): on a flat road the object that
  /// touches the ground lower in the image stands nearer to the camera and hides the others.
  /// Equal y_max: the higher score wins, then the earlier detection.
  bool exclusive_assignment = false;
  /// Which cells vote for the motion (and give the velocity). kCluster leaves out the cells of
  /// other objects that the band collects around a small one (walls, parked cars, the ground
  /// beside a pedestrian); the cluster is formed at centre.cluster_distance. kRegion (the
  /// default) is the paper's rule: every cell of the band.
  MotionVote motion_vote = MotionVote::kRegion;
  /// What the fusion stage reports as the position (fuse() itself always gives the median).
  PositionSource position = PositionSource::kCentre;
  /// The centre estimate (used with PositionSource::kCentre).
  CentreConfig centre;

  /// @throws std::invalid_argument naming the first bad field (band fractions must be finite
  ///         and in [0, 10], min_points >= 1, centre as CentreConfig::validate()).
  void validate() const;
};

/// Owning structure-of-arrays point set; view() lends it to fuse().
struct ProjectedPoints
{
  std::vector<float> u, v, x, y, vx, vy;
  std::vector<std::uint8_t> state;
  /// Scans since each point's cell last held obstacle points; optional (empty: none given,
  /// add() leaves it so).
  std::vector<std::uint8_t> scans_since_hit;
  /// The cells' occupied masses and velocity variances; optional (empty: none given, add()
  /// leaves them so).
  std::vector<float> p_static, p_dynamic, v_var_x, v_var_y;
  /// The grid's cell size [m] (0: not given).
  double resolution = 0.0;

  /// Appends one point.
  void add(float pu, float pv, float px, float py, float pvx, float pvy, CellState s);
  std::size_t size() const { return u.size(); }
  ProjectedPointsView view() const;
};

/// The fusion band of one box: x_min < u < x_max and top < v < bottom (strict inequalities).
struct FusionRegion
{
  float u_min = 0.F;
  float u_max = 0.F;
  float v_min = 0.F;  ///< y_max − a·h
  float v_max = 0.F;  ///< y_max + b·h

  /// The band of `box` for the fractions of `config`.
  static FusionRegion fromBox(const BoundingBox& box, const FusionConfig& config);
  /// Whether pixel (u, v) lies strictly inside the band; false for NaN coordinates.
  bool contains(float u, float v) const { return u > u_min && u < u_max && v > v_min && v < v_max; }
};

/// What the fusion finds of one detection's object in one image: its band's cells, their vote and
/// its positions. Each field has one meaning and is set by one step (fuse(), estimateCentres(),
/// placeOnGround()); what is reported of the object is its ReportedObject.
struct FusedObject
{
  std::size_t detection_index = 0;  ///< index of the box in the detection list
  /// Whether the object's band holds grid cells (kCells) or not (kBox: its position comes from its
  /// box, placeOnGround()). Never kTrack: that is a report's (ReportedObject::support).
  ObjectSupport support = ObjectSupport::kCells;
  std::uint32_t static_points = 0;   ///< static cells of the vote (region or cluster)
  std::uint32_t dynamic_points = 0;  ///< dynamic cells of the vote
  /// The vote's verdict (decideMotion()): the paper's per-frame motion; kUnknown without cells.
  Motion vote = Motion::kUnknown;
  /// The vote's dynamic share d / (s + d), [0, 1]; 0.5 without cells.
  double dynamic_share = 0.5;
  /// Median velocity of the vote's dynamic cells [m/s], fixed frame; 0 unless the vote is kDynamic.
  double vote_vx = 0.0;
  double vote_vy = 0.0;
  /// Median x, y of the band's cells [m] (the paper's position, the object's near face), from
  /// fuse(); for an object without cells, its box's place on the ground (placeOnGround()), NaN
  /// before.
  double median_x = 0.0;
  double median_y = 0.0;
  /// The object's centre [m] (estimateCentres(), placeOnGround()); NaN before.
  double centre_x = std::numeric_limits<double>::quiet_NaN();
  double centre_y = std::numeric_limits<double>::quiet_NaN();
  /// The object's length [m] (CentreEstimate::length), set by estimateCentres(): where its box is
  /// cut by the image edge, how far its centre may lie off the estimate.
  double length = 0.0;
  /// What the grid says about the object's motion, from the cells of its cluster (gridEvidence()).
  GridMotionEvidence grid;
  std::vector<std::uint32_t> members;  ///< indices of the region's valid points
  /// The object's own cells among the members: objectCluster() at centre.cluster_distance.
  std::vector<std::uint32_t> cluster;

  /// Its position by `source`: the centre or the median (x, y) [m].
  Eigen::Vector2d position(PositionSource source) const;
};

/// What is reported of one object of an image: the fields of its DetectedObject message. Made once
/// per image: from the object's track (trackObjects()) or, in the paper's per-frame mode, from its
/// fusion band alone (reportPerFrame()).
struct ReportedObject
{
  /// The track id; per frame: the index of its detection (FusedObject::detection_index).
  std::uint32_t id = 0;
  /// The track's label (the one its objects had most often) and its detector class index; per
  /// frame: the detection's.
  std::string label;
  std::uint32_t class_id = 0;
  TrackState track_state = TrackState::kNone;  ///< kNone per frame
  /// What its position and motion rest on: kCells, kTrack (no cells: its track's prediction) or
  /// kBox (no cells and no track that knows where it is: its box's place on the ground).
  ObjectSupport support = ObjectSupport::kCells;
  Motion motion = Motion::kUnknown;
  /// P(dynamic), [0, 1]: the track's; per frame the vote's dynamic share.
  double p_dynamic = 0.5;
  double x = 0.0;  ///< position [m], fixed frame
  double y = 0.0;
  double vx = 0.0;       ///< velocity [m/s]; 0 unless kDynamic
  double vy = 0.0;       ///< velocity [m/s]; 0 unless kDynamic
  double heading = 0.0;  ///< atan2(vy, vx) [rad]; 0 unless kDynamic

  double speed() const;
};

/// Result of fuse(): one object per detection, in detection order; then one report per object.
struct FusionResult
{
  std::vector<FusedObject> objects;
  /// reports[i] is objects[i]'s: empty after fuse(), made by reportPerFrame() or trackObjects().
  std::vector<ReportedObject> reports;
  /// Points skipped because a coordinate, a velocity or the state was invalid (NaN/Inf,
  /// unknown state value).
  std::size_t invalid_points = 0;
  /// The reports come from the tracker: ids are track ids, motion and state the track's.
  bool tracked = false;
};

/// Median of `values` (average of the two middle values for an even count).
/// Reorders `values`. @throws std::invalid_argument when empty.
double median(std::vector<double>& values);

/// What the grid says about the motion of the object made of the points `cells`: the mean
/// dynamic share P(D) / (P(S) + P(D)) of the cells (their state, 1 or 0, where the view carries
/// no masses; 0.5 without cells) and, where the view carries the velocity variances, the cells'
/// velocities weighted by their dynamic share with their variance (particles' spread plus the
/// spread of the cells' means).
GridMotionEvidence gridEvidence(const ProjectedPointsView& points, const std::vector<std::uint32_t>& cells);

/// Motion of a region from its cardinalities (larger set wins; tie and minimum count per
/// `config`). Returns kUnknown for an empty region.
Motion decideMotion(std::uint32_t static_points, std::uint32_t dynamic_points, const FusionConfig& config);

/// Fuses the detector boxes with the projected grid points: builds the fusion region of every
/// box, collects the valid points inside it and computes its point-wise features (the median of
/// the region; the vote, its share and velocity from the cells config.motion_vote names). A region
/// without any point still gives its object, with vote kUnknown, support kBox and no position yet
/// (NaN: placeOnGround() gives it one). No reports yet (reportPerFrame(), trackObjects()). Points with a
/// non-finite u, v, x or y, a non-finite velocity on a dynamic point, or a state that is neither STATIC nor
/// DYNAMIC are skipped. `expected` (empty, or one list per detection): the cells the detection's track
/// expects (Tracker::priors()), which objectCluster() prefers.
FusionResult fuse(const std::vector<Detection>& detections, const ProjectedPointsView& points,
                  const FusionConfig& config, const std::vector<std::vector<Eigen::Vector2d>>& expected = {});

/// Sets the centre (centre_x, centre_y) and length of every object of `result` with cells:
/// estimateCentre() over its members (centreOfCluster() of its cluster when fuse() has found one),
/// with the footprint of its detection's label (config.footprints), seen from the camera at
/// (`camera_x`, `camera_y`) in the frame of the points [m].
/// @throws std::invalid_argument when an object's detection_index or members do not fit
///         `detections` and `points`.
void estimateCentres(FusionResult& result, const std::vector<Detection>& detections,
                     const ProjectedPointsView& points, double camera_x, double camera_y,
                     const CentreConfig& config);

/// Where an image's pixels meet the ground: the grid frame → pixel matrix P · (camera ← grid) at
/// the image stamp (a grid-frame point X lands on w·(u, v, 1)ᵀ = M·(X, 1)ᵀ, w > 0 in front of the
/// camera) and the z of the ground plane in the grid frame [m].
struct ImageGround
{
  Eigen::Matrix<double, 3, 4> grid_to_image = Eigen::Matrix<double, 3, 4>::Zero();
  double ground_z = 0.0;

  /// Whether the matrix is a camera's (finite, its left 3×3 invertible) and ground_z finite.
  bool valid() const;
  /// Where the line of sight through pixel (u, v) meets the ground plane (x, y in the grid frame)
  /// [m]; a line that meets it behind the camera, above the horizon, or farther than `max_range`
  /// [m] from the camera gives the point at max_range along its horizontal direction.
  Eigen::Vector2d groundPoint(double u, double v, double max_range) const;
  /// The camera's optical centre (x, y) in the grid frame [m].
  Eigen::Vector2d cameraPosition() const;
};

/// How far from the camera a box without cells is placed at most [m], when its bottom edge looks
/// at the ground farther away or not at all (above the horizon).
constexpr double kMaxBoxGroundRange = 150.0;

/// Gives every object of `result` without cells (support kBox) a position from its box, as its
/// centre and its median: the point of the ground plane its bottom-centre pixel looks at
/// (ImageGround::groundPoint()), moved along the line of sight by half the mean of its label's
/// footprint (`footprints`; none: 0), the centre of an object whose near face stands on the box's
/// bottom edge. Without a valid `ground`, such objects keep no position (NaN).
void placeOnGround(FusionResult& result, const std::vector<Detection>& detections, const ImageGround& ground,
                   const std::map<std::string, Footprint>& footprints);

/// The paper's per-frame mode: every object of `result` reported from its band alone: id its
/// detection's index, the detection's label and class, the vote's verdict, share and velocity, and its
/// position by `position` (support kBox objects: their place on the ground). Replaces
/// result.reports; result.tracked becomes false.
void reportPerFrame(FusionResult& result, const std::vector<Detection>& detections, PositionSource position);

/// Checks that a detections/points pair can be fused: boxes finite, x_min <= x_max,
/// y_min <= y_max and inside the image (1 px tolerance), and the image sizes of both inputs
/// equal. Returns an empty string when they can, else a message naming what is wrong.
std::string checkFusionInputs(const std::vector<Detection>& detections, std::uint32_t detections_width,
                              std::uint32_t detections_height, std::uint32_t points_width,
                              std::uint32_t points_height);

}  // namespace grid_vision_fusion
