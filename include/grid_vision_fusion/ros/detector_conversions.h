// The detector's ROS layer: image encodings → core pixel formats, core detections →
// Detection2DArray, private parameters → YoloDetectorConfig / DetectionReplayConfig.
#pragma once

#include <ros/node_handle.h>
#include <std_msgs/Header.h>

#include <string>
#include <vector>

#include "grid_vision_fusion/Detection2DArray.h"
#include "grid_vision_fusion/detection/detection_replay.h"
#include "grid_vision_fusion/types.h"
#include "grid_vision_fusion/detection/yolo_detector.h"
#include "grid_vision_fusion/ros/params.h"

namespace grid_vision_fusion
{
/// The pixel format of a sensor_msgs/Image encoding: "rgb8", "bgr8" or "mono8".
/// @throws std::invalid_argument naming the encoding for any other.
PixelFormat pixelFormatFromEncoding(const std::string& encoding);

/// The Detection2DArray of `detections`: header = `image_header` (stamp, frame_id and seq of the
/// image), image size filled, detections in the given order (empty array when none).
Detection2DArray::Ptr detectionsToMsg(const std_msgs::Header& image_header, std::uint32_t image_width,
                                      std::uint32_t image_height, const std::vector<Detection>& detections);

/// YoloDetectorConfig from the private parameters model, weights, class_names, input_width,
/// input_height, resize_mode ("letterbox"|"resize"), network_rgb, onnx_layout
/// ("pixels"|"opencv_region"), score_threshold, nms_threshold, dnn_backend, dnn_target and
/// class_map (a dictionary). @throws std::invalid_argument on a wrong type or a value that
/// YoloDetectorConfig::validate() rejects.
YoloDetectorConfig yoloDetectorConfigFromParams(const ParamSource& params);
YoloDetectorConfig yoloDetectorConfigFromParams(const ros::NodeHandle& nh);

/// DetectionReplayConfig from the private parameters replay/directory, replay/file_pattern,
/// replay/frame_index ("counter"|"seq"), replay/first_index, replay/class_map,
/// replay/default_score, replay/missing_file_is_empty and score_threshold.
/// @throws std::invalid_argument on a wrong type or a value that validate() rejects.
DetectionReplayConfig detectionReplayConfigFromParams(const ParamSource& params);
DetectionReplayConfig detectionReplayConfigFromParams(const ros::NodeHandle& nh);

}  // namespace grid_vision_fusion
