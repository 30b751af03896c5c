#include "grid_vision_fusion/ros/detector_conversions.h"

#include <sensor_msgs/image_encodings.h>
#include <boost/make_shared.hpp>

#include <map>
#include <stdexcept>

#include "grid_vision_fusion/ros/params.h"

namespace grid_vision_fusion
{
PixelFormat pixelFormatFromEncoding(const std::string& encoding)
{
  namespace enc = sensor_msgs::image_encodings;
  if (encoding == enc::BGR8)
  {
    return PixelFormat::kBgr8;
  }
  if (encoding == enc::RGB8)
  {
    return PixelFormat::kRgb8;
  }
  if (encoding == enc::MONO8)
  {
    return PixelFormat::kMono8;
  }
  throw std::invalid_argument("image encoding \"" + encoding +
                              "\" is not supported (use rgb8, bgr8 or mono8)");
}

Detection2DArray::Ptr detectionsToMsg(const std_msgs::Header& image_header, std::uint32_t image_width,
                                      std::uint32_t image_height, const std::vector<Detection>& detections)
{
  auto msg = boost::make_shared<Detection2DArray>();
  msg->header = image_header;
  msg->image_width = image_width;
  msg->image_height = image_height;
  msg->detections.reserve(detections.size());
  for (const Detection& d : detections)
  {
    Detection2D out;
    out.class_id = d.class_id;
    out.label = d.label;
    out.score = d.score;
    out.x_min = d.box.x_min;
    out.y_min = d.box.y_min;
    out.x_max = d.box.x_max;
    out.y_max = d.box.y_max;
    msg->detections.push_back(out);
  }
  return msg;
}

YoloDetectorConfig yoloDetectorConfigFromParams(const ParamSource& nh)
{
  YoloDetectorConfig config;
  readParam(nh, "model", config.model_path);
  readParam(nh, "weights", config.weights_path);
  readParam(nh, "class_names", config.class_names_path);
  readParam(nh, "input_width", config.input_width);
  readParam(nh, "input_height", config.input_height);
  std::string resize_mode = toString(config.resize_mode);
  readParam(nh, "resize_mode", resize_mode);
  config.resize_mode = resizeModeFromString(resize_mode);
  readParam(nh, "network_rgb", config.network_rgb);
  std::string onnx_layout = "pixels";
  readParam(nh, "onnx_layout", onnx_layout);
  if (onnx_layout == "pixels")
  {
    config.onnx_layout = YoloOutputLayout::kPixels;
  }
  else if (onnx_layout == "opencv_region")
  {
    config.onnx_layout = YoloOutputLayout::kOpenCvRegion;
  }
  else
  {
    throw std::invalid_argument("parameter " + nh.describe("onnx_layout") +
                                " must be \"pixels\" or \"opencv_region\", got \"" + onnx_layout + "\"");
  }
  readParam(nh, "score_threshold", config.score_threshold);
  readParam(nh, "nms_threshold", config.nms_threshold);
  readParam(nh, "dnn_backend", config.backend);
  readParam(nh, "dnn_target", config.target);
  readParam(nh, "class_map", config.class_map);
  config.validate();
  return config;
}

DetectionReplayConfig detectionReplayConfigFromParams(const ParamSource& nh)
{
  DetectionReplayConfig config;
  readParam(nh, "replay/directory", config.directory);
  readParam(nh, "replay/file_pattern", config.file_pattern);
  std::string frame_index = toString(config.index_source);
  readParam(nh, "replay/frame_index", frame_index);
  config.index_source = frameIndexSourceFromString(frame_index);
  readParam(nh, "replay/first_index", config.first_index);
  readParam(nh, "replay/class_map", config.class_map);
  readParam(nh, "replay/default_score", config.default_score);
  readParam(nh, "replay/missing_file_is_empty", config.missing_file_is_empty);
  readParam(nh, "score_threshold", config.score_threshold);
  config.validate();
  return config;
}

YoloDetectorConfig yoloDetectorConfigFromParams(const ros::NodeHandle& nh)
{
  return yoloDetectorConfigFromParams(NodeHandleParamSource(nh));
}

DetectionReplayConfig detectionReplayConfigFromParams(const ros::NodeHandle& nh)
{
  return detectionReplayConfigFromParams(NodeHandleParamSource(nh));
}

}  // namespace grid_vision_fusion
