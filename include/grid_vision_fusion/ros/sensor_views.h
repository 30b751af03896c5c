// Views of the sensor messages that arrive from outside: the float32 x, y, z of a
// sensor_msgs/PointCloud2 and the pixels of a sensor_msgs/Image, checked against the message's
// layout and never copied.
#pragma once

#include <sensor_msgs/Image.h>
#include <sensor_msgs/PointCloud2.h>
#include <opencv2/core.hpp>

#include <string>

#include "grid_vision_fusion/detection/detector.h"
#include "grid_vision_fusion/grid/inverse_sensor_model.h"

namespace grid_vision_fusion
{
/// Points `view` at the float32 x, y, z fields of `cloud` (no copy; the view is valid while
/// `cloud` lives). Returns an empty string on success, otherwise what is wrong (missing field,
/// field not float32, big-endian data, point_step or row_step inconsistent with the data).
std::string pointCloudViewOf(const sensor_msgs::PointCloud2& cloud, PointCloudView& view);

/// The pixel format of a sensor_msgs/Image encoding: "rgb8", "bgr8" or "mono8".
/// @throws std::invalid_argument naming the encoding for any other.
PixelFormat pixelFormatFromEncoding(const std::string& encoding);

/// Empty when `image` holds the pixels its header claims, whatever its encoding: width and
/// height > 0, an encoding sensor_msgs knows, step >= width × bytes per pixel and step × height
/// bytes of data; otherwise what is wrong, e.g. "data holds 10 bytes, step * height needs
/// 1200000000". cv_bridge refuses such an image too, but with its own wording and only once it
/// converts it: the nodelets check at arrival, with one wording.
std::string checkImageData(const sensor_msgs::Image& image);

/// Points `pixels` at the data of `image` (no copy; valid while `image` lives): CV_8UC3 for
/// rgb8 and bgr8, CV_8UC1 for mono8, image.step bytes per row, and sets `format`. Returns an
/// empty string on success, otherwise what is wrong (unsupported encoding, or checkImageData()'s
/// answer).
std::string imageViewOf(const sensor_msgs::Image& image, cv::Mat& pixels, PixelFormat& format);

}  // namespace grid_vision_fusion
