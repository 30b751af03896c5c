#include "grid_vision_fusion/ros_stages/detector_stage.h"

#include "grid_vision_fusion/detection/detection_replay.h"
#include "grid_vision_fusion/detection/yolo_detector.h"
#include "grid_vision_fusion/ros/detector_conversions.h"
#include "grid_vision_fusion/ros/sensor_views.h"

namespace grid_vision_fusion
{
DetectorStage::DetectorStage(const DetectorParams& params) : params_(params)
{
  if (params_.backend == "replay")
  {
    detector_ = std::make_unique<DetectionReplay>(params_.replay);
  }
  else if (params_.backend == "opencv_dnn")
  {
    detector_ = std::make_unique<YoloDetector>(params_.yolo);
  }
  else
  {
    throw std::invalid_argument("detector backend must be \"opencv_dnn\" or \"replay\", got \"" +
                                params_.backend + "\"");
  }
}

std::vector<Detection> DetectorStage::detect(const sensor_msgs::Image::ConstPtr& image,
                                             std::int64_t frame_index)
{
  DetectorImage input;
  input.width = image->width;
  input.height = image->height;
  input.frame_index = frame_index;
  if (detector_->needsPixels())
  {
    const std::string error = imageViewOf(*image, input.pixels, input.format);
    if (!error.empty())
    {
      throw std::invalid_argument("image: " + error);
    }
  }
  return detector_->detect(input);
}

}  // namespace grid_vision_fusion
