// The detector interface: what the detector stage asks of a source of 2-D detections, a YOLO
// network (YoloDetector) or the replay of per-frame label files (DetectionReplay).
#pragma once

#include <opencv2/core.hpp>

#include <cstdint>
#include <string>
#include <vector>

#include "grid_vision_fusion/types.h"

namespace grid_vision_fusion
{
/// Detections scoring below this are dropped, whichever the detector: the one default of the
/// detector's score_threshold.
constexpr double kDefaultScoreThreshold = 0.5;

/// Channel layout of an image handed to a detector.
enum class PixelFormat
{
  kBgr8,   ///< CV_8UC3, blue first
  kRgb8,   ///< CV_8UC3, red first
  kMono8,  ///< CV_8UC1, replicated to three channels
};

/// One image as a detector receives it.
struct DetectorImage
{
  cv::Mat pixels;  ///< the image; left empty for a detector that does not need pixels
  PixelFormat format = PixelFormat::kBgr8;
  std::uint32_t width = 0;        ///< [px]
  std::uint32_t height = 0;       ///< [px]
  std::int64_t frame_index = -1;  ///< what Detector::frameIndex() gave at the image's arrival
};

/// A source of 2-D detections, one image at a time. Not thread-safe.
class Detector
{
public:
  virtual ~Detector() = default;

  /// Called for every image in the order of arrival, also for those dropped later (a detector
  /// slower than the camera keeps the newest image only): the index under which the image will
  /// be detected, so that a replay of per-frame files stays in step with the camera. -1 for a
  /// detector that needs none. @throws std::out_of_range when no valid index results.
  virtual std::int64_t frameIndex(std::uint32_t /*header_seq*/) { return -1; }
  /// Whether detect() looks at DetectorImage::pixels.
  virtual bool needsPixels() const = 0;
  /// The detections of `image`: boxes in its pixels, clipped to it.
  /// @throws std::invalid_argument for an image it cannot process; what the backend throws
  ///         (e.g. a malformed label file).
  virtual std::vector<Detection> detect(const DetectorImage& image) = 0;
  /// Changes the score threshold and, where the detector suppresses overlaps, the NMS IoU.
  /// @throws std::invalid_argument outside [0, 1].
  virtual void setThresholds(double score_threshold, double nms_threshold) = 0;
  /// One line for logs and diagnostics: the model and its backend, or what is replayed.
  virtual std::string description() const = 0;
  /// What went differently than configured while loading (e.g. a backend fallback).
  virtual std::vector<std::string> warnings() const { return {}; }
};

}  // namespace grid_vision_fusion
