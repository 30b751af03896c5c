// Checks of a sensor_msgs/Image before its pixels are read. cv_bridge refuses a wrongly formed
// image too, but with its own wording and only once the image is converted; this check names
// the fault the same way for every nodelet, at arrival, and also refuses a 0 x 0 image.
#pragma once

#include <sensor_msgs/Image.h>

#include <string>

namespace grid_vision_fusion
{
/// Empty when `image` holds the pixels its header claims: width and height > 0, a known
/// encoding, step >= width × bytes per pixel and step × height bytes of data; otherwise what is
/// wrong, e.g. "data holds 10 bytes, step * height needs 1200000000".
std::string checkImageData(const sensor_msgs::Image& image);

}  // namespace grid_vision_fusion
