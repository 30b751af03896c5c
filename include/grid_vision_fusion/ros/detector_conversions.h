// The detector's messages: image encodings → core pixel formats, core detections →
// Detection2DArray.
#pragma once

#include <std_msgs/Header.h>

#include <string>
#include <vector>

#include "grid_vision_fusion/Detection2DArray.h"
#include "grid_vision_fusion/detection/detector.h"
#include "grid_vision_fusion/ros/sensor_views.h"

namespace grid_vision_fusion
{
/// The Detection2DArray of `detections`: header = `image_header` (stamp, frame_id and seq of the
/// image), image size filled, detections in the given order (empty array when none).
Detection2DArray::Ptr detectionsToMsg(const std_msgs::Header& image_header, std::uint32_t image_width,
                                      std::uint32_t image_height, const std::vector<Detection>& detections);

}  // namespace grid_vision_fusion
