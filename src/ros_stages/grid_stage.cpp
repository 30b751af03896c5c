#include "grid_vision_fusion/ros_stages/grid_stage.h"

#include <tf2_eigen/tf2_eigen.h>

#include "grid_vision_fusion/ros/grid_conversions.h"

namespace grid_vision_fusion
{
GridStage::GridStage(const DynamicGridParams& params) : params_(params), filter_(params.filter)
{
  header_.frame_id = params_.fixed_frame;
}

DynamicGridCycle GridStage::update(const sensor_msgs::PointCloud2& cloud, const tf2::BufferCore& tf)
{
  PointCloudView view;
  const std::string field_error = pointCloudViewOf(cloud, view);
  if (!field_error.empty())
  {
    throw UnusableMessage(field_error);
  }
  const Eigen::Isometry3d world_from_sensor = tf2::transformToEigen(
      tf.lookupTransform(params_.fixed_frame, cloud.header.frame_id, cloud.header.stamp));
  const DynamicGridCycle cycle = filter_.update(view, world_from_sensor, cloud.header.stamp.toSec());
  header_.stamp = cloud.header.stamp;
  return cycle;
}

DynamicGrid::Ptr GridStage::gridMsg() const
{
  return dynamicGridToMsg(filter_, header_);
}

nav_msgs::OccupancyGrid::Ptr GridStage::occupancyMsg() const
{
  return occupancyGridToMsg(filter_, header_);
}

sensor_msgs::PointCloud2::Ptr GridStage::cellsMsg() const
{
  return gridCellsToCloud(filter_, header_);
}

}  // namespace grid_vision_fusion
