#include "grid_vision_fusion/ros/grid_conversions.h"

#include <sensor_msgs/point_cloud2_iterator.h>
#include <boost/make_shared.hpp>

#include <algorithm>
#include <cmath>
#include <cstring>

#include "grid_vision_fusion/ros/params.h"

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

DynamicGridConfig dynamicGridConfigFromParams(const ParamSource& nh)
{
  DynamicGridConfig c;
  readParam(nh, "width", c.width);
  readParam(nh, "height", c.height);
  readParam(nh, "resolution", c.resolution);
  readParam(nh, "lookahead", c.lookahead);
  readParam(nh, "max_time_gap", c.max_time_gap);
  readParam(nh, "transition_period", c.transition_period);
  readParam(nh, "eps_static_to_dynamic", c.eps_static_to_dynamic);
  readParam(nh, "eps_static_to_unknown", c.eps_static_to_unknown);
  readParam(nh, "eps_dynamic_to_static", c.eps_dynamic_to_static);
  readParam(nh, "eps_dynamic_to_unknown", c.eps_dynamic_to_unknown);
  readParam(nh, "eps_free_to_static", c.eps_free_to_static);
  readParam(nh, "eps_free_to_dynamic", c.eps_free_to_dynamic);
  readParam(nh, "eps_free_to_unknown", c.eps_free_to_unknown);
  readParam(nh, "eps_unknown_to_static", c.eps_unknown_to_static);
  readParam(nh, "eps_unknown_to_dynamic", c.eps_unknown_to_dynamic);
  readParam(nh, "eps_unknown_to_free", c.eps_unknown_to_free);
  readParam(nh, "particle_count", c.particle_count);
  readParam(nh, "birth_fraction", c.birth_fraction);
  readParam(nh, "birth_velocity_sigma", c.birth_velocity_sigma);
  readParam(nh, "birth_motion_speed", c.birth_motion_speed);
  readParam(nh, "birth_motion_fraction", c.birth_motion_fraction);
  readParam(nh, "acceleration_sigma", c.acceleration_sigma);
  readParam(nh, "max_speed", c.max_speed);
  readParam(nh, "vacated_to_dynamic", c.vacated_to_dynamic);
  readParam(nh, "motion_window", c.motion_window);
  readParam(nh, "motion_radius", c.motion_radius);
  readParam(nh, "motion_memory", c.motion_memory);
  readParam(nh, "unknown_to_dynamic_by_motion", c.unknown_to_dynamic_by_motion);
  readParam(nh, "static_to_dynamic_by_motion", c.static_to_dynamic_by_motion);
  readParam(nh, "inherit_birth_velocity", c.inherit_birth_velocity);
  readParam(nh, "propagation_rate", c.propagation_rate);
  readParam(nh, "propagation_length", c.propagation_length);
  int seed = static_cast<int>(c.seed);
  readParam(nh, "seed", seed);
  if (seed < 0)
  {
    throw std::invalid_argument("parameter " + nh.describe("seed") + " must be >= 0, got " +
                                std::to_string(seed));
  }
  c.seed = static_cast<std::uint32_t>(seed);
  readParam(nh, "dynamic_threshold", c.dynamic_threshold);
  readParam(nh, "min_dynamic_speed", c.min_dynamic_speed);
  readParam(nh, "mahalanobis_threshold", c.mahalanobis_threshold);
  readParam(nh, "occupied_threshold", c.occupied_threshold);
  InverseSensorModelConfig& m = c.sensor_model;
  readParam(nh, "sensor_height", m.sensor_height);
  readParam(nh, "min_range", m.min_range);
  readParam(nh, "max_range", m.max_range);
  readParam(nh, "angular_resolution", m.angular_resolution);
  readParam(nh, "range_resolution", m.range_resolution);
  readParam(nh, "max_ground_slope", m.max_ground_slope);
  readParam(nh, "ground_tolerance", m.ground_tolerance);
  readParam(nh, "min_obstacle_height", m.min_obstacle_height);
  readParam(nh, "max_obstacle_height", m.max_obstacle_height);
  readParam(nh, "p_occupied", m.p_occupied);
  readParam(nh, "p_free", m.p_free);
  readParam(nh, "range_sigma", m.range_sigma);
  readParam(nh, "hit_neighbours_not_free", m.hit_neighbours_not_free);
  c.validate();
  return c;
}

DynamicGridConfig dynamicGridConfigFromParams(const ros::NodeHandle& nh)
{
  return dynamicGridConfigFromParams(NodeHandleParamSource(nh));
}

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
  msg->is_dense = true;
  return msg;
}

}  // namespace grid_vision_fusion
