// The types the on-vehicle stages share: detector boxes, motion and cell states, and the view of
// projected grid points that the projection produces and the fusion consumes.
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <string>

namespace grid_vision_fusion
{
/// Motion class of an object; the values equal the DetectedObject.msg MOTION_* constants.
enum class Motion : std::uint8_t
{
  kUnknown = 0,
  kStatic = 1,
  kDynamic = 2,
};

/// "static", "dynamic" or "unknown".
inline std::string toString(Motion motion)
{
  switch (motion)
  {
    case Motion::kStatic:
      return "static";
    case Motion::kDynamic:
      return "dynamic";
    case Motion::kUnknown:
      break;
  }
  return "unknown";
}

/// State of an object's track; the values equal the DetectedObject.msg TRACK_* constants.
enum class TrackState : std::uint8_t
{
  kNone = 0,       ///< not tracked (the per-frame output)
  kTentative = 1,  ///< a new track, not yet confirmed
  kConfirmed = 2,  ///< a track with enough images
};

/// State of a projected grid cell; the values equal the ProjectedGrid.msg constants.
enum class CellState : std::uint8_t
{
  kStatic = 1,
  kDynamic = 2,
};

/// An axis-aligned detector box in pixels (x right, y down).
struct BoundingBox
{
  float x_min = 0.F;
  float y_min = 0.F;
  float x_max = 0.F;
  float y_max = 0.F;

  float height() const { return y_max - y_min; }
  /// The box clipped to a `width` x `height` image [px].
  BoundingBox clippedTo(std::uint32_t width, std::uint32_t height) const
  {
    const float w = static_cast<float>(width);
    const float h = static_cast<float>(height);
    return {std::clamp(x_min, 0.F, w), std::clamp(y_min, 0.F, h), std::clamp(x_max, 0.F, w),
            std::clamp(y_max, 0.F, h)};
  }
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
  /// Scans since each point's cell last held obstacle points (0: the grid's scan); optional
  /// (nullptr: every point counts as seen in the grid's scan).
  const std::uint8_t* scans_since_hit = nullptr;
  /// The cell's occupied masses P(static) and P(dynamic), [0, 1]; optional (nullptr: not given).
  const float* p_static = nullptr;
  const float* p_dynamic = nullptr;
  /// Variances of the cell's velocity given dynamic [m²/s²]; optional (nullptr: not given).
  const float* v_var_x = nullptr;
  const float* v_var_y = nullptr;
  /// The grid's cell size [m]: the step of the lattice x and y lie on; 0: not given.
  double resolution = 0.0;
};

/// The view of any structure of arrays with members u, v, x, y, vx, vy (float vectors) and
/// state (uint8 vector) of equal length, resolution (a number), and scans_since_hit (uint8
/// vector, optional: empty or of that length), e.g. ProjectedPoints or a ProjectedGrid message.
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
  view.resolution = arrays.resolution;
  if (arrays.scans_since_hit.size() == view.size && view.size > 0)
  {
    view.scans_since_hit = arrays.scans_since_hit.data();
  }
  if (arrays.p_static.size() == view.size && arrays.p_dynamic.size() == view.size && view.size > 0)
  {
    view.p_static = arrays.p_static.data();
    view.p_dynamic = arrays.p_dynamic.data();
  }
  if (arrays.v_var_x.size() == view.size && arrays.v_var_y.size() == view.size && view.size > 0)
  {
    view.v_var_x = arrays.v_var_x.data();
    view.v_var_y = arrays.v_var_y.data();
  }
  return view;
}

}  // namespace grid_vision_fusion
