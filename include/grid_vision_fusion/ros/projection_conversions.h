// Conversions for the grid projection: DynamicGrid → core grid view (no copy), CameraInfo →
// pinhole camera, projected cells → ProjectedGrid (moved, no copy).
#pragma once

#include <sensor_msgs/CameraInfo.h>
#include <std_msgs/Header.h>

#include <string>

#include "grid_vision_fusion/DynamicGrid.h"
#include "grid_vision_fusion/ProjectedGrid.h"
#include "grid_vision_fusion/projection/grid_projection.h"

namespace grid_vision_fusion
{
/// Empty when `msg` can be projected: p_static, p_dynamic, vx, vy hold width·height elements,
/// the resolution is finite and > 0, the origin finite and its orientation the identity (the
/// grid axes are those of the frame). Otherwise a message naming what is wrong.
std::string checkDynamicGrid(const DynamicGrid& msg);

/// A view borrowing the arrays of `msg` (no copy). Only valid while `msg` lives, and only after
/// checkDynamicGrid() returned empty.
GridCellsView gridCellsViewOf(const DynamicGrid& msg);

/// The pinhole camera of the rectified projection matrix P of `msg` and its image size.
/// @throws std::invalid_argument with a message naming the field at fault: P all zeros
///         ("P missing", an uncalibrated camera), a zero focal length, size 0 (see PinholeCamera).
PinholeCamera pinholeFromCameraInfo(const sensor_msgs::CameraInfo& msg);

/// The ProjectedGrid of `cells`: header = the camera_info header (stamp and optical frame),
/// grid_stamp and grid_frame_id from `grid_header`, image size from `camera`. The arrays of
/// `cells` are moved into the message (left empty).
ProjectedGrid::Ptr projectedGridToMsg(ProjectedCells&& cells, const std_msgs::Header& image_header,
                                      const std_msgs::Header& grid_header, const PinholeCamera& camera);

}  // namespace grid_vision_fusion
