// Fusion regions and point-wise feature processing (Gómez et al., §III-C and §III-D).
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace grid_vision_fusion
{
/// Motion class of an object; the values equal the DetectedObject.msg MOTION_* constants.
enum class Motion : std::uint8_t
{
  kUnknown = 0,
  kStatic = 1,
  kDynamic = 2,
};

/// State of a projected grid cell; the values equal the ProjectedGrid.msg constants.
enum class CellState : std::uint8_t
{
  kStatic = 1,
  kDynamic = 2,
};

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
/// "static", "dynamic" or "unknown".
std::string toString(Motion motion);

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

  /// @throws std::invalid_argument naming the first bad field (band fractions must be finite
  ///         and in [0, 10], min_points >= 1).
  void validate() const;
};

/// An axis-aligned detector box in pixels (x right, y down).
struct BoundingBox
{
  float x_min = 0.F;
  float y_min = 0.F;
  float x_max = 0.F;
  float y_max = 0.F;

  float height() const { return y_max - y_min; }
};

/// One detector output.
struct Detection
{
  std::uint32_t class_id = 0;
  std::string label;
  float score = 0.F;
  BoundingBox box;
};

/// Read-only view of the projected grid points, structure of arrays, all of length `size`.
/// It borrows the arrays (e.g. those of a ProjectedGrid message) and copies nothing.
struct ProjectedPointsView
{
  std::size_t size = 0;
  const float* u = nullptr;             ///< pixel column [px]
  const float* v = nullptr;             ///< pixel row [px]
  const float* x = nullptr;             ///< cell position x [m], grid frame
  const float* y = nullptr;             ///< cell position y [m], grid frame
  const float* vx = nullptr;            ///< cell velocity x [m/s], grid frame
  const float* vy = nullptr;            ///< cell velocity y [m/s], grid frame
  const std::uint8_t* state = nullptr;  ///< CellState values
};

/// The view of any structure of arrays with members u, v, x, y, vx, vy (float vectors) and
/// state (uint8 vector) of equal length, e.g. ProjectedPoints or a ProjectedGrid message.
template <typename PointArrays>
ProjectedPointsView pointsViewOf(const PointArrays& arrays)
{
  ProjectedPointsView view;
  view.size = arrays.u.size();
  view.u = arrays.u.data();
  view.v = arrays.v.data();
  view.x = arrays.x.data();
  view.y = arrays.y.data();
  view.vx = arrays.vx.data();
  view.vy = arrays.vy.data();
  view.state = arrays.state.data();
  return view;
}

/// Owning structure-of-arrays point set; view() lends it to fuse().
struct ProjectedPoints
{
  std::vector<float> u, v, x, y, vx, vy;
  std::vector<std::uint8_t> state;

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

/// The point-wise features of one non-empty fusion region.
struct FusedObject
{
  std::size_t detection_index = 0;  ///< index of the box in the detection list
  Motion motion = Motion::kUnknown;
  std::uint32_t static_points = 0;
  std::uint32_t dynamic_points = 0;
  double x = 0.0;        ///< median x of all region points [m]
  double y = 0.0;        ///< median y of all region points [m]
  double vx = 0.0;       ///< median vx of the dynamic points [m/s]; 0 unless kDynamic
  double vy = 0.0;       ///< median vy of the dynamic points [m/s]; 0 unless kDynamic
  double heading = 0.0;  ///< atan2(vy, vx) [rad]; 0 unless kDynamic

  double speed() const;
};

/// Result of fuse(): one object per non-empty region, in detection order.
struct FusionResult
{
  std::vector<FusedObject> objects;
  /// Points skipped because a coordinate, a velocity or the state was invalid (NaN/Inf,
  /// unknown state value).
  std::size_t invalid_points = 0;
};

/// Median of `values` (average of the two middle values for an even count).
/// Reorders `values`. @throws std::invalid_argument when empty.
double median(std::vector<double>& values);

/// Motion of a region from its cardinalities (larger set wins; tie and minimum count per
/// `config`). Returns kUnknown for an empty region.
Motion decideMotion(std::uint32_t static_points, std::uint32_t dynamic_points, const FusionConfig& config);

/// Fuses the detector boxes with the projected grid points: builds the fusion region of every
/// box, collects the valid points inside it and computes its point-wise features. Regions
/// without any point are discarded. Points with a non-finite u, v, x or y, a non-finite
/// velocity on a dynamic point, or a state that is neither STATIC nor DYNAMIC are skipped.
FusionResult fuse(const std::vector<Detection>& detections, const ProjectedPointsView& points,
                  const FusionConfig& config);

/// Checks that a detections/points pair can be fused: boxes finite, x_min <= x_max,
/// y_min <= y_max and inside the image (1 px tolerance), and the image sizes of both inputs
/// equal. Returns an empty string when they can, else a message naming what is wrong.
std::string checkFusionInputs(const std::vector<Detection>& detections, std::uint32_t detections_width,
                              std::uint32_t detections_height, std::uint32_t points_width,
                              std::uint32_t points_height);

}  // namespace grid_vision_fusion
