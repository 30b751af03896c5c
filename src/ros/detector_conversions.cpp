#include "grid_vision_fusion/ros/detector_conversions.h"

#include <boost/make_shared.hpp>

#include <map>
#include <stdexcept>

namespace grid_vision_fusion
{
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

}  // namespace grid_vision_fusion
