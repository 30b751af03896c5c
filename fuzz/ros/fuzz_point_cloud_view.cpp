// Fuzz harness: the field layout of a sensor_msgs/PointCloud2, pointCloudViewOf(); every point
// of an accepted view is read as the grid filter reads it.
#include <cstring>

#include "fuzz_input.h"
#include "grid_vision_fusion/ros/sensor_views.h"

GVF_FUZZ_TARGET(point_cloud_view)
{
  gvf_fuzz::ByteReader in(data, size);
  sensor_msgs::PointCloud2 cloud;
  const char* const names[] = {"x", "y", "z", "intensity"};
  const int fields = in.take<std::uint8_t>() % 6;
  for (int i = 0; i < fields; ++i)
  {
    sensor_msgs::PointField field;
    const std::uint8_t name = in.take<std::uint8_t>();
    field.name = name < 4 ? names[name] : in.takeString(3);
    field.offset = in.take<std::uint32_t>();
    field.datatype = in.take<std::uint8_t>();
    field.count = in.take<std::uint32_t>();
    cloud.fields.push_back(field);
  }
  cloud.width = in.take<std::uint32_t>();
  cloud.height = in.take<std::uint32_t>();
  cloud.point_step = in.take<std::uint32_t>();
  cloud.row_step = in.take<std::uint32_t>();
  cloud.is_bigendian = in.take<std::uint8_t>() % 2;
  cloud.data = in.rest();

  grid_vision_fusion::PointCloudView view;
  if (!grid_vision_fusion::pointCloudViewOf(cloud, view).empty())
  {
    return 0;
  }
  float sum = 0.F;
  for (std::size_t row = 0; row < view.height; ++row)
  {
    for (std::size_t col = 0; col < view.width; ++col)
    {
      const std::uint8_t* p = view.data + row * view.row_step + col * view.point_step;
      float xyz[3];
      std::memcpy(&xyz[0], p + view.x_offset, sizeof(float));
      std::memcpy(&xyz[1], p + view.y_offset, sizeof(float));
      std::memcpy(&xyz[2], p + view.z_offset, sizeof(float));
      sum += xyz[0] + xyz[1] + xyz[2];
    }
  }
  gvf_fuzz::keep(sum);
  return 0;
}
