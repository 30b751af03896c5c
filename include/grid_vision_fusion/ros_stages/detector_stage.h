// The detector stage: an image in, its Detection2DArray out, through the Detector the
// parameters choose (a YOLO network on OpenCV DNN, or the replay of per-frame label files).
// Shared by the yolo_detector nodelet and the offline Pipeline.
#pragma once

#include <sensor_msgs/Image.h>

#include <memory>
#include <vector>

#include "grid_vision_fusion/Detection2DArray.h"
#include "grid_vision_fusion/detection/detector.h"
#include "grid_vision_fusion/ros/node_params.h"

namespace grid_vision_fusion
{
/// The detector with its parameters. Not thread-safe.
class DetectorStage
{
public:
  /// Builds the detector of params.backend. @throws std::invalid_argument for invalid params;
  /// what the detector throws while loading (YoloModelError naming the file).
  explicit DetectorStage(const DetectorParams& params);

  /// Call for every image as it arrives, also for those dropped later: its frame index
  /// (Detector::frameIndex()). @throws std::out_of_range when no valid index results.
  std::int64_t frameIndex(const sensor_msgs::Image& image) { return detector_->frameIndex(image.header.seq); }

  /// The detections of `image` (viewed without a copy when the detector needs its pixels).
  /// @throws std::invalid_argument for an unsupported encoding or an image without the data its
  ///         header claims (checkImageData()); what Detector::detect() throws.
  std::vector<Detection> detect(const sensor_msgs::Image::ConstPtr& image, std::int64_t frame_index);

  /// Changes the score and NMS thresholds. @throws std::invalid_argument outside [0, 1].
  void setThresholds(double score_threshold, double nms_threshold)
  {
    detector_->setThresholds(score_threshold, nms_threshold);
  }

  const DetectorParams& params() const { return params_; }
  Detector& detector() { return *detector_; }
  const Detector& detector() const { return *detector_; }

private:
  DetectorParams params_;
  std::unique_ptr<Detector> detector_;
};

}  // namespace grid_vision_fusion
