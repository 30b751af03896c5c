// Detections as KITTI object result files: what a 2-D detector submits to the KITTI benchmark,
// and what the replay backend (detection_replay.h) reads back, so that a slow network can run
// once and its detections be replayed many times.
#pragma once

#include <string>

#include "grid_vision_fusion/detection/kitti_labels.h"
#include "grid_vision_fusion/types.h"

namespace grid_vision_fusion
{
/// The KITTI type a detection label is written as: the KITTI object type (kittiObjectTypes())
/// equal to it ignoring case ("car" → "Car", "person_sitting" → "Person_sitting"); any other
/// label as it is, with each whitespace character replaced by '_' (a type is one field:
/// "traffic light" → "traffic_light"). @throws std::invalid_argument for an empty label.
std::string kittiTypeOfLabel(const std::string& label);

/// A detection as a line of a KITTI object result file: type kittiTypeOfLabel(label), the 2-D
/// box [px] and the score; the fields a 2-D detector does not estimate hold KITTI's "unknown"
/// values, as result files do: truncated and occluded -1, alpha -10, height, width and length
/// -1, location -1000, rotation_y -10.
KittiObjectLabel kittiResultOf(const Detection& detection);

}  // namespace grid_vision_fusion
