#include "grid_vision_fusion/ros/sensor_views.h"

#include <sensor_msgs/image_encodings.h>

#include <cstdint>
#include <stdexcept>

namespace grid_vision_fusion
{
std::string pointCloudViewOf(const sensor_msgs::PointCloud2& cloud, PointCloudView& view)
{
  const char* names[3] = {"x", "y", "z"};
  std::size_t offsets[3] = {0, 0, 0};
  for (int k = 0; k < 3; ++k)
  {
    const sensor_msgs::PointField* found = nullptr;
    for (const auto& field : cloud.fields)
    {
      if (field.name == names[k])
      {
        found = &field;
      }
    }
    if (!found)
    {
      return std::string("no field '") + names[k] + "'";
    }
    if (found->datatype != sensor_msgs::PointField::FLOAT32 || found->count != 1)
    {
      return std::string("field '") + names[k] + "' is not a single float32 (datatype " +
             std::to_string(found->datatype) + ", count " + std::to_string(found->count) + ")";
    }
    if (found->offset + sizeof(float) > cloud.point_step)
    {
      return std::string("field '") + names[k] + "' lies beyond point_step " +
             std::to_string(cloud.point_step);
    }
    offsets[k] = found->offset;
  }
  if (cloud.is_bigendian)
  {
    return "big-endian point data is not supported";
  }
  const std::size_t points = static_cast<std::size_t>(cloud.width) * cloud.height;
  if (points > 0)
  {
    if (static_cast<std::size_t>(cloud.width) * cloud.point_step > cloud.row_step)
    {
      return "row_step " + std::to_string(cloud.row_step) + " < width * point_step";
    }
    if (static_cast<std::size_t>(cloud.row_step) * cloud.height > cloud.data.size())
    {
      return "data holds " + std::to_string(cloud.data.size()) + " bytes, row_step * height needs " +
             std::to_string(static_cast<std::size_t>(cloud.row_step) * cloud.height);
    }
  }
  view.data = cloud.data.data();
  view.width = points > 0 ? cloud.width : 0;
  view.height = points > 0 ? cloud.height : 0;
  view.point_step = cloud.point_step;
  view.row_step = cloud.row_step;
  view.x_offset = offsets[0];
  view.y_offset = offsets[1];
  view.z_offset = offsets[2];
  return std::string();
}

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

std::string checkImageData(const sensor_msgs::Image& image)
{
  namespace enc = sensor_msgs::image_encodings;
  if (image.width == 0 || image.height == 0)
  {
    return "image is empty (" + std::to_string(image.width) + "x" + std::to_string(image.height) + ")";
  }
  std::uint64_t bytes_per_pixel = 0;
  try
  {
    bytes_per_pixel = static_cast<std::uint64_t>(enc::numChannels(image.encoding)) *
                      static_cast<std::uint64_t>(enc::bitDepth(image.encoding)) / 8;
  }
  catch (const std::runtime_error&)
  {
    return "unknown image encoding \"" + image.encoding + "\"";
  }
  const std::uint64_t min_step = static_cast<std::uint64_t>(image.width) * bytes_per_pixel;
  if (image.step < min_step)
  {
    return "step " + std::to_string(image.step) + " < width * bytes per pixel = " + std::to_string(min_step);
  }
  const std::uint64_t needed = static_cast<std::uint64_t>(image.step) * image.height;
  if (image.data.size() < needed)
  {
    return "data holds " + std::to_string(image.data.size()) + " bytes, step * height needs " +
           std::to_string(needed);
  }
  return {};
}

std::string imageViewOf(const sensor_msgs::Image& image, cv::Mat& pixels, PixelFormat& format)
{
  try
  {
    format = pixelFormatFromEncoding(image.encoding);
  }
  catch (const std::invalid_argument& e)
  {
    return e.what();
  }
  const std::string error = checkImageData(image);
  if (!error.empty())
  {
    return error;
  }
  // cv::Mat counts rows and columns in int.
  if (image.width > static_cast<std::uint32_t>(INT32_MAX) ||
      image.height > static_cast<std::uint32_t>(INT32_MAX))
  {
    return "image of " + std::to_string(image.width) + "x" + std::to_string(image.height) + " is too large";
  }
  pixels = cv::Mat(static_cast<int>(image.height), static_cast<int>(image.width),
                   format == PixelFormat::kMono8 ? CV_8UC1 : CV_8UC3,
                   const_cast<std::uint8_t*>(image.data.data()), image.step);
  return std::string();
}

}  // namespace grid_vision_fusion
