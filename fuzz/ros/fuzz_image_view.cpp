// Fuzz harness: the pixel layout of a sensor_msgs/Image, imageViewOf(); every pixel of an
// accepted view is read.
#include "fuzz_input.h"
#include "grid_vision_fusion/ros/sensor_views.h"

GVF_FUZZ_TARGET(image_view)
{
  gvf_fuzz::ByteReader in(data, size);
  sensor_msgs::Image image;
  const char* const encodings[] = {"rgb8", "bgr8", "mono8", "rgba8", "mono16"};
  const std::uint8_t encoding = in.take<std::uint8_t>();
  image.encoding = encoding < 5 ? encodings[encoding] : in.takeString(8);
  image.width = in.take<std::uint32_t>();
  image.height = in.take<std::uint32_t>();
  image.step = in.take<std::uint32_t>();
  image.is_bigendian = in.take<std::uint8_t>() % 2;
  image.data = in.rest();

  cv::Mat pixels;
  grid_vision_fusion::PixelFormat format;
  if (!grid_vision_fusion::imageViewOf(image, pixels, format).empty())
  {
    return 0;
  }
  unsigned sum = 0;
  const int row_bytes = pixels.cols * static_cast<int>(pixels.elemSize());
  for (int row = 0; row < pixels.rows; ++row)
  {
    const std::uint8_t* p = pixels.ptr<std::uint8_t>(row);
    for (int i = 0; i < row_bytes; ++i)
    {
      sum += p[i];
    }
  }
  gvf_fuzz::keep(sum);
  return 0;
}
