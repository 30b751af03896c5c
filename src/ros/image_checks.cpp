#include "grid_vision_fusion/ros/image_checks.h"

#include <sensor_msgs/image_encodings.h>

#include <stdexcept>

namespace grid_vision_fusion
{
std::string checkImageData(const sensor_msgs::Image& image)
{
  namespace enc = sensor_msgs::image_encodings;
  if (image.width == 0 || image.height == 0)
  {
    return "image is empty (" + std::to_string(image.width) + "x" + std::to_string(image.height) + ")";
  }
  std::size_t bytes_per_pixel = 0;
  try
  {
    bytes_per_pixel = static_cast<std::size_t>(enc::numChannels(image.encoding)) *
                      static_cast<std::size_t>(enc::bitDepth(image.encoding)) / 8;
  }
  catch (const std::runtime_error&)
  {
    return "unknown image encoding \"" + image.encoding + "\"";
  }
  const std::size_t min_step = static_cast<std::size_t>(image.width) * bytes_per_pixel;
  if (image.step < min_step)
  {
    return "step " + std::to_string(image.step) + " < width * bytes per pixel " + std::to_string(min_step);
  }
  const std::size_t needed = static_cast<std::size_t>(image.step) * image.height;
  if (image.data.size() < needed)
  {
    return "data holds " + std::to_string(image.data.size()) + " bytes, step * height needs " +
           std::to_string(needed);
  }
  return {};
}

}  // namespace grid_vision_fusion
