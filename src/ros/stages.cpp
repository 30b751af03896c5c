#include "grid_vision_fusion/ros/stages.h"

#include <cv_bridge/cv_bridge.h>
#include <tf2/exceptions.h>
#include <tf2_eigen/tf2_eigen.h>

#include <cmath>
#include <memory>

#include "grid_vision_fusion/ros/detector_conversions.h"
#include "grid_vision_fusion/ros/fusion_conversions.h"
#include "grid_vision_fusion/ros/projection_conversions.h"

namespace grid_vision_fusion
{
DynamicGridNodeOptions dynamicGridNodeOptionsFromParams(const ParamSource& params)
{
  DynamicGridNodeOptions o;
  readParam(params, "fixed_frame", o.fixed_frame);
  readParam(params, "lazy", o.lazy);
  readParam(params, "queue_size", o.queue_size);
  readParam(params, "expected_rate", o.expected_rate);
  if (o.fixed_frame.empty())
  {
    throw std::invalid_argument("parameter " + params.describe("fixed_frame") + " must not be empty");
  }
  if (o.queue_size < 1)
  {
    throw std::invalid_argument("parameter " + params.describe("queue_size") + " must be >= 1, got " +
                                std::to_string(o.queue_size));
  }
  if (!(o.expected_rate > 0.0) || !std::isfinite(o.expected_rate))
  {
    throw std::invalid_argument("parameter " + params.describe("expected_rate") + " must be > 0 [Hz]");
  }
  return o;
}

Eigen::Isometry3d scanPose(const tf2::BufferCore& tf, const std::string& fixed_frame,
                           const std::string& sensor_frame, const ros::Time& stamp)
{
  return tf2::transformToEigen(tf.lookupTransform(fixed_frame, sensor_frame, stamp));
}

GridProjectionNodeOptions gridProjectionNodeOptionsFromParams(const ParamSource& params)
{
  GridProjectionNodeOptions o;
  readParam(params, "ground_frame", o.ground_frame);
  readParam(params, "ground_height", o.ground_height);
  readParam(params, "max_grid_age", o.max_grid_age);
  readParam(params, "image_cache_size", o.image_cache_size);
  readParam(params, "lazy", o.lazy);
  if (!std::isfinite(o.ground_height))
  {
    throw std::invalid_argument("parameter " + params.describe("ground_height") + " must be finite");
  }
  if (!std::isfinite(o.max_grid_age) || o.max_grid_age <= 0.0)
  {
    throw std::invalid_argument("parameter " + params.describe("max_grid_age") +
                                " must be finite and > 0 s, got " + std::to_string(o.max_grid_age));
  }
  if (o.image_cache_size < 1)
  {
    throw std::invalid_argument("parameter " + params.describe("image_cache_size") + " must be >= 1, got " +
                                std::to_string(o.image_cache_size));
  }
  return o;
}

double groundZInGridFrame(const tf2::BufferCore& tf, const GridProjectionNodeOptions& options,
                          const std::string& grid_frame, const ros::Time& stamp)
{
  if (options.ground_frame.empty())
  {
    return options.ground_height;
  }
  const Eigen::Isometry3d grid_from_ground =
      tf2::transformToEigen(tf.lookupTransform(grid_frame, options.ground_frame, stamp));
  return (grid_from_ground * Eigen::Vector3d(0.0, 0.0, options.ground_height)).z();
}

ProjectedGrid::Ptr projectGridIntoCamera(const DynamicGrid& grid, const sensor_msgs::CameraInfo& info,
                                         const tf2::BufferCore& tf, const GridProjectionNodeOptions& options,
                                         const GridProjectionConfig& config, std::size_t* invalid_cells)
{
  std::unique_ptr<PinholeCamera> camera;
  try
  {
    camera = std::make_unique<PinholeCamera>(pinholeFromCameraInfo(info));
  }
  catch (const std::invalid_argument& e)
  {
    throw ProjectionSkipped("unusable camera_info (frame '" + info.header.frame_id + "'): " + e.what());
  }
  const ros::Time& image_stamp = info.header.stamp;
  const double grid_age = (image_stamp - grid.header.stamp).toSec();
  if (std::abs(grid_age) > options.max_grid_age)
  {
    throw ProjectionSkipped("the latest grid (t=" + std::to_string(grid.header.stamp.toSec()) + ") is " +
                            std::to_string(grid_age) + " s away from the image, more than max_grid_age " +
                            std::to_string(options.max_grid_age) + " s");
  }
  ProjectionGeometry geometry;
  geometry.time_offset = grid_age;
  try
  {
    geometry.camera_from_grid =
        tf2::transformToEigen(tf.lookupTransform(info.header.frame_id, grid.header.frame_id, image_stamp));
  }
  catch (const tf2::TransformException& e)
  {
    throw ProjectionSkipped("no tf " + info.header.frame_id + " <- " + grid.header.frame_id + ": " +
                            e.what());
  }
  try
  {
    geometry.ground_z = groundZInGridFrame(tf, options, grid.header.frame_id, image_stamp);
  }
  catch (const tf2::TransformException& e)
  {
    throw ProjectionSkipped("no tf " + grid.header.frame_id + " <- " + options.ground_frame +
                            " (ground_frame): " + e.what());
  }
  ProjectedCells cells;
  try
  {
    cells = projectGrid(gridCellsViewOf(grid), *camera, geometry, config);
  }
  catch (const std::invalid_argument& e)
  {
    throw ProjectionSkipped(std::string("cannot project the grid: ") + e.what());
  }
  if (invalid_cells)
  {
    *invalid_cells = cells.cells_invalid;
  }
  return projectedGridToMsg(std::move(cells), info.header, grid.header, *camera);
}

std::vector<Detection> detectInImage(YoloDetector& detector, const sensor_msgs::Image::ConstPtr& image)
{
  const PixelFormat format = pixelFormatFromEncoding(image->encoding);
  const cv_bridge::CvImageConstPtr view = cv_bridge::toCvShare(image);
  return detector.detect(view->image, format);
}

FusedPair fusePair(const Detection2DArray& detections, const ProjectedGrid& grid, const FusionConfig& config)
{
  const std::string grid_error = checkProjectedGrid(grid);
  if (!grid_error.empty())
  {
    throw std::invalid_argument("projected grid: " + grid_error);
  }
  FusedPair pair;
  pair.detections = detectionsFromMsg(detections);
  const std::string input_error = checkFusionInputs(
      pair.detections, detections.image_width, detections.image_height, grid.image_width, grid.image_height);
  if (!input_error.empty())
  {
    throw std::invalid_argument(input_error);
  }
  pair.result = fuse(pair.detections, viewOf(grid), config);
  pair.objects = objectsToMsg(detections.header, grid.grid_frame_id, pair.detections, pair.result);
  return pair;
}

}  // namespace grid_vision_fusion
