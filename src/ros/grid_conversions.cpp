#include "grid_vision_fusion/ros/grid_conversions.h"

#include <sensor_msgs/point_cloud2_iterator.h>
#include <boost/make_shared.hpp>

#include <algorithm>
#include <cmath>
#include <cstring>

namespace grid_vision_fusion
{
namespace
{
float packRgb(std::uint8_t r, std::uint8_t g, std::uint8_t b)
{
  const std::uint32_t rgb = (static_cast<std::uint32_t>(r) << 16) | (static_cast<std::uint32_t>(g) << 8) | b;
  float packed;
  std::memcpy(&packed, &rgb, sizeof(packed));
  return packed;
}
}  // namespace

namespace
{
/// The map metadata of the grid: resolution, size and the corner of cell (0, 0), axes aligned.
nav_msgs::MapMetaData mapMetaData(const GridGeometry& g, const ros::Time& stamp)
{
  nav_msgs::MapMetaData info;
  info.map_load_time = stamp;
  info.resolution = static_cast<float>(g.resolution);
  info.width = static_cast<std::uint32_t>(g.width);
  info.height = static_cast<std::uint32_t>(g.height);
  info.origin.position.x = g.originX();
  info.origin.position.y = g.originY();
  info.origin.orientation.w = 1.0;
  return info;
}
}  // namespace

DynamicGrid::Ptr dynamicGridToMsg(const DynamicGridFilter& filter, const std_msgs::Header& header)
{
  auto msg = boost::make_shared<DynamicGrid>();
  msg->header = header;
  const GridGeometry& g = filter.geometry();
  msg->info = mapMetaData(g, header.stamp);
  const CellStates& s = filter.cells();
  msg->p_static = s.p_static;
  msg->p_dynamic = s.p_dynamic;
  msg->p_free = s.p_free;
  msg->p_unknown = s.p_unknown;
  msg->vx = s.vx;
  msg->vy = s.vy;
  msg->v_var_x = s.v_var_x;
  msg->v_var_y = s.v_var_y;
  msg->scans_since_hit.resize(g.cellCount());
  for (std::size_t i = 0; i < msg->scans_since_hit.size(); ++i)
  {
    msg->scans_since_hit[i] = filter.scansSinceHit(i);
  }
  filter.cellGroundHeights(msg->ground_z);
  return msg;
}

nav_msgs::OccupancyGrid::Ptr occupancyGridToMsg(const DynamicGridFilter& filter,
                                                const std_msgs::Header& header)
{
  auto msg = boost::make_shared<nav_msgs::OccupancyGrid>();
  msg->header = header;
  const GridGeometry& g = filter.geometry();
  msg->info = mapMetaData(g, header.stamp);
  const CellStates& s = filter.cells();
  msg->data.resize(g.cellCount());
  for (std::size_t i = 0; i < g.cellCount(); ++i)
  {
    const float known = 1.0F - s.p_unknown[i];
    if (s.p_unknown[i] >= 0.5F || known <= 0.0F)
    {
      msg->data[i] = -1;
      continue;
    }
    const float occupied = std::min(1.0F, (s.p_static[i] + s.p_dynamic[i]) / known);
    msg->data[i] = static_cast<std::int8_t>(std::lround(100.0F * std::max(0.0F, occupied)));
  }
  return msg;
}

sensor_msgs::PointCloud2::Ptr gridCellsToCloud(const DynamicGridFilter& filter,
                                               const std_msgs::Header& header)
{
  auto msg = boost::make_shared<sensor_msgs::PointCloud2>();
  msg->header = header;
  sensor_msgs::PointCloud2Modifier modifier(*msg);
  modifier.setPointCloud2Fields(7, "x", 1, sensor_msgs::PointField::FLOAT32, "y", 1,
                                sensor_msgs::PointField::FLOAT32, "z", 1, sensor_msgs::PointField::FLOAT32,
                                "rgb", 1, sensor_msgs::PointField::FLOAT32, "vx", 1,
                                sensor_msgs::PointField::FLOAT32, "vy", 1, sensor_msgs::PointField::FLOAT32,
                                "p_dynamic", 1, sensor_msgs::PointField::FLOAT32);
  const GridGeometry& g = filter.geometry();
  const CellStates& s = filter.cells();
  std::size_t count = 0;
  for (std::size_t i = 0; i < g.cellCount(); ++i)
  {
    const CellClass c = filter.classify(i);
    count += (c == CellClass::kStatic || c == CellClass::kDynamic) ? 1 : 0;
  }
  modifier.resize(count);
  msg->is_dense = true;
  if (count == 0)
  {
    return msg;  // an iterator over no data would bind a reference to data.front() (UB)
  }
  sensor_msgs::PointCloud2Iterator<float> it(*msg, "x");
  const auto z = static_cast<float>(filter.groundZ());
  const float blue = packRgb(0, 0, 255);
  for (int row = 0; row < g.height; ++row)
  {
    for (int col = 0; col < g.width; ++col)
    {
      const std::size_t i = g.index(row, col);
      const CellClass c = filter.classify(i);
      if (c != CellClass::kStatic && c != CellClass::kDynamic)
      {
        continue;
      }
      // Fields are consecutive float32: x y z rgb vx vy p_dynamic.
      float* p = &(*it);
      p[0] = static_cast<float>(g.cellCenterX(col));
      p[1] = static_cast<float>(g.cellCenterY(row));
      p[2] = z;
      p[3] = c == CellClass::kDynamic ? packRgb(0,
                                                static_cast<std::uint8_t>(std::lround(
                                                    255.0F * std::clamp(s.p_dynamic[i], 0.0F, 1.0F))),
                                                0)
                                      : blue;
      p[4] = s.vx[i];
      p[5] = s.vy[i];
      p[6] = s.p_dynamic[i];
      ++it;
    }
  }
  return msg;
}

}  // namespace grid_vision_fusion
