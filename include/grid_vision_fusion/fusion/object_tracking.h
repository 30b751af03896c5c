// The fused objects of an image through the tracker: the stage between fuse() and the message.
#pragma once

#include <Eigen/Core>

#include <cstdint>
#include <vector>

#include "grid_vision_fusion/fusion/fusion.h"
#include "grid_vision_fusion/fusion/tracker.h"
#include "grid_vision_fusion/types.h"

namespace grid_vision_fusion
{
/// Runs `tracker` on the objects of `result` at `stamp_s` [s]: every object becomes a track
/// observation (label and box of its detection, its position by `position`, whether the box
/// touches the left or right edge of an image `image_width` pixels wide, the grid's evidence of
/// its cells, its cluster's cells in `points`), and every cell of `points` the lidar hit in the
/// grid's scan is a hit of the scene (Tracker::update()); `camera` is the camera's position
/// (Tracker::update()). Every object's report (result.reports, replaced) is its track's: id, label,
/// state (tentative or confirmed), P(dynamic), verdict, filtered position and, when dynamic,
/// velocity and heading (static and unknown ones zero, as the message says). An object without
/// cells is reported with motion unknown at its track's predicted position when the track has one
/// (support kTrack), else at its box's (support kBox). Sets result.tracked.
void trackObjects(Tracker& tracker, double stamp_s, const std::vector<Detection>& detections,
                  std::uint32_t image_width, const ProjectedPointsView& points, FusionResult& result,
                  const Eigen::Vector2d& camera = Eigen::Vector2d::Constant(kNotKnown),
                  PositionSource position = PositionSource::kCentre);

}  // namespace grid_vision_fusion
