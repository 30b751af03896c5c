// Messages <-> dynamic grid core: PointCloud2 views, DynamicGrid, OccupancyGrid and the
// grid/cells point cloud.
#pragma once

#include <nav_msgs/OccupancyGrid.h>
#include <sensor_msgs/PointCloud2.h>
#include <std_msgs/Header.h>

#include <string>

#include "grid_vision_fusion/DynamicGrid.h"
#include "grid_vision_fusion/grid/dynamic_grid_filter.h"
#include "grid_vision_fusion/ros/sensor_views.h"

namespace grid_vision_fusion
{
/// The filter's grid as a DynamicGrid (header given: scan stamp, fixed frame).
DynamicGrid::Ptr dynamicGridToMsg(const DynamicGridFilter& filter, const std_msgs::Header& header);

/// nav_msgs/OccupancyGrid of the filter's grid: -1 where P(U) >= 0.5, otherwise
/// round(100 (P(S) + P(D)) / (1 - P(U))) in [0, 100].
nav_msgs::OccupancyGrid::Ptr occupancyGridToMsg(const DynamicGridFilter& filter,
                                                const std_msgs::Header& header);

/// One point per occupied cell (CellClass static or dynamic) for rviz, at the cell centre and
/// the ground height below the sensor; fields x, y, z, rgb, vx, vy, p_dynamic (float32).
/// Static cells blue (0, 0, 255); dynamic cells green (0, round(255 P(D)), 0).
sensor_msgs::PointCloud2::Ptr gridCellsToCloud(const DynamicGridFilter& filter,
                                               const std_msgs::Header& header);

}  // namespace grid_vision_fusion
