// Conversions between the fusion messages and the core fusion types.
#pragma once

#include <visualization_msgs/MarkerArray.h>

#include <string>
#include <vector>

#include "grid_vision_fusion/DetectedObjectArray.h"
#include "grid_vision_fusion/Detection2DArray.h"
#include "grid_vision_fusion/ProjectedGrid.h"
#include "grid_vision_fusion/fusion/fusion.h"

namespace grid_vision_fusion
{
/// The detections of a Detection2DArray as core detections.
std::vector<Detection> detectionsFromMsg(const Detection2DArray& msg);

/// Empty when every per-point array of `msg` has the same length, else a message naming the
/// arrays and their lengths.
std::string checkProjectedGrid(const ProjectedGrid& msg);

/// A view borrowing the arrays of `msg` (no copy). Only valid while `msg` lives, and only
/// after checkProjectedGrid() returned empty.
ProjectedPointsView viewOf(const ProjectedGrid& msg);

/// Where the image of `msg` meets the ground (its grid_to_image and ground_z); an invalid
/// ImageGround when the message does not carry them (all zeros).
ImageGround imageGroundOf(const ProjectedGrid& msg);

/// The DetectedObjectArray of a fusion result: header.stamp = the image stamp,
/// header.frame_id = `grid_frame_id`, image_frame_id = the camera frame of `image_header`;
/// each object's fields from its report (result.reports), its cell counts from its FusedObject.
/// @throws std::invalid_argument when result.reports does not hold one report per object.
DetectedObjectArray::Ptr objectsToMsg(const std_msgs::Header& image_header, const std::string& grid_frame_id,
                                      const std::vector<Detection>& detections, const FusionResult& result);

/// rviz markers for `objects`: a DELETEALL first, then per object a cylinder at its position
/// (static blue, dynamic green, unknown grey), an arrow along the velocity of dynamic objects
/// (length = 1 s of travel) and a text label such as "dynamic car 4.2 m/s", with `with_ids`
/// (ids are track ids) "#12 dynamic car 4.2 m/s".
visualization_msgs::MarkerArray::Ptr objectsToMarkers(const DetectedObjectArray& objects, bool with_ids);

}  // namespace grid_vision_fusion
