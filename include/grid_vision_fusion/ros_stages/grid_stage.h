// The dynamic grid stage: a lidar scan and its pose from tf in, the filtered grid's messages out.
// Shared by the dynamic_grid nodelet and the offline Pipeline.
#pragma once

#include <nav_msgs/OccupancyGrid.h>
#include <sensor_msgs/PointCloud2.h>
#include <tf2/buffer_core.h>

#include <stdexcept>

#include "grid_vision_fusion/DynamicGrid.h"
#include "grid_vision_fusion/grid/dynamic_grid_filter.h"
#include "grid_vision_fusion/ros/node_params.h"

namespace grid_vision_fusion
{
/// A message a stage cannot use at all (e.g. a cloud without float32 x, y, z fields).
class UnusableMessage : public std::invalid_argument
{
public:
  using std::invalid_argument::invalid_argument;
};

/// The filter with its parameters. Not thread-safe.
class GridStage
{
public:
  /// @throws std::invalid_argument when `params` is invalid.
  explicit GridStage(const DynamicGridParams& params);

  /// One filter cycle for `cloud` with the sensor pose tf gives at its stamp (fixed_frame ←
  /// cloud frame, no waiting). The grid messages below then carry the cloud's stamp.
  /// @throws UnusableMessage naming what is wrong with the cloud's fields;
  ///         tf2::TransformException when tf cannot answer.
  DynamicGridCycle update(const sensor_msgs::PointCloud2& cloud, const tf2::BufferCore& tf);

  /// A cloud that arrived but is not filtered: a newer one replaced it while the filter was busy
  /// (DynamicGridFilter::skipScan()).
  void skip(const sensor_msgs::PointCloud2& cloud) { filter_.skipScan(cloud.header.stamp.toSec()); }

  /// The grid of the last update() as a DynamicGrid (fixed frame, the scan's stamp).
  DynamicGrid::Ptr gridMsg() const;
  /// ... as a nav_msgs/OccupancyGrid (see occupancyGridToMsg()).
  nav_msgs::OccupancyGrid::Ptr occupancyMsg() const;
  /// ... as the grid/cells point cloud for rviz (see gridCellsToCloud()).
  sensor_msgs::PointCloud2::Ptr cellsMsg() const;

  /// Replaces the reporting thresholds by those of `thresholds` (dynamic_reconfigure).
  /// @throws std::invalid_argument as DynamicGridConfig::validate().
  void setClassification(const DynamicGridConfig& thresholds) { filter_.setClassification(thresholds); }

  const DynamicGridParams& params() const { return params_; }
  const DynamicGridFilter& filter() const { return filter_; }

private:
  DynamicGridParams params_;
  DynamicGridFilter filter_;
  std_msgs::Header header_;  ///< stamp of the last scan, the fixed frame
};

}  // namespace grid_vision_fusion
