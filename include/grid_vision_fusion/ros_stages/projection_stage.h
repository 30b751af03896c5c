// The grid projection stage: a DynamicGrid and a camera's CameraInfo in, the occupied cells
// projected into that camera's image out (ProjectedGrid stamped like the image). Shared by the
// grid_projection nodelet and the offline Pipeline.
#pragma once

#include <sensor_msgs/CameraInfo.h>
#include <tf2/buffer_core.h>

#include <algorithm>
#include <stdexcept>
#include <string>
#include <vector>

#include "grid_vision_fusion/DynamicGrid.h"
#include "grid_vision_fusion/ProjectedGrid.h"
#include "grid_vision_fusion/ros/node_params.h"

namespace grid_vision_fusion
{
/// Why a camera_info produced no projected grid.
class ProjectionSkipped : public std::runtime_error
{
public:
  using std::runtime_error::runtime_error;
};

/// What ProjectionStage::project() tells besides its message.
struct ProjectionNotes
{
  /// Cells skipped for NaN/Inf values.
  std::size_t invalid_cells = 0;
  /// Why the message holds no cell although the grid has some: the grid is too old for the image
  /// (maxGridAge()). Empty when the grid was projected.
  std::string cells_left_out;
};

/// The projection with its parameters. Stateless between calls; project() may run concurrently.
class ProjectionStage
{
public:
  /// @throws std::invalid_argument when `params` is invalid.
  explicit ProjectionStage(const GridProjectionParams& params);

  /// The projection of `grid` into the camera of `info`: camera from CameraInfo, camera ← grid
  /// transform and ground height from tf at the image stamp, projectGrid(), ProjectedGrid stamped
  /// like the image. A grid older than maxGridAge() says too little of the image's scene: the
  /// message then holds no cell, only the geometry (camera position, grid_to_image, ground_z), so
  /// that the fusion still publishes the image's detections, placed by their boxes or tracks
  /// (motion unknown), and `notes->cells_left_out` says why. `grid` must have passed
  /// checkDynamicGrid(). `notes` (when given) receives what else there is to tell.
  /// `grid_interval`: how far apart the grids come [s] (StampCadence).
  /// @throws ProjectionSkipped with the reason (unusable camera_info, no tf).
  ProjectedGrid::Ptr project(const DynamicGrid& grid, const sensor_msgs::CameraInfo& info,
                             const tf2::BufferCore& tf, ProjectionNotes* notes = nullptr,
                             double grid_interval = 0.0) const;

  /// The largest |t_image − t_grid| whose cells are projected when the grids come `grid_interval`
  /// apart [s]: max_grid_age, or kGridIntervalsOfAge intervals when the grid stage delivers its
  /// grids further apart (a filter slower than its lidar skips scans: overload). The newest grid
  /// there is can be that old (StampCadence). The cells of a grid stream that stops are left out
  /// once its last grid is older than that.
  double maxGridAge(double grid_interval) const
  {
    return std::max(params_.max_grid_age, kGridIntervalsOfAge * grid_interval);
  }

  /// A grid's age in grid intervals that overload may give it: the newest grid is as old as the
  /// interval before it (the cycle that made it) and the one that has not ended yet (the cycle
  /// under way, which may be the longest so far): two, and one more for that one's length
  /// (doc/reliability.md, "Overload").
  static constexpr double kGridIntervalsOfAge = 3.0;

  /// The frames tf must know, besides the camera's, to project a grid of `grid_frame`.
  std::vector<std::string> tfFrames(const std::string& grid_frame) const;

  const GridProjectionParams& params() const { return params_; }

private:
  /// z of the ground plane in `grid_frame` at `stamp` (see GridProjectionParams::ground_frame).
  double groundZ(const tf2::BufferCore& tf, const std::string& grid_frame, const ros::Time& stamp) const;

  GridProjectionParams params_;
};

}  // namespace grid_vision_fusion
