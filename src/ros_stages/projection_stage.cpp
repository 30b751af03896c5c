#include "grid_vision_fusion/ros_stages/projection_stage.h"

#include <tf2/exceptions.h>
#include <tf2_eigen/tf2_eigen.h>

#include <cmath>
#include <memory>

#include "grid_vision_fusion/ros/projection_conversions.h"

namespace grid_vision_fusion
{
ProjectionStage::ProjectionStage(const GridProjectionParams& params) : params_(params)
{
  params_.projection.validate();
}

std::vector<std::string> ProjectionStage::tfFrames(const std::string& grid_frame) const
{
  std::vector<std::string> frames{grid_frame};
  if (!params_.ground_frame.empty() && params_.ground_frame != grid_frame)
  {
    frames.push_back(params_.ground_frame);
  }
  return frames;
}

double ProjectionStage::groundZ(const tf2::BufferCore& tf, const std::string& grid_frame,
                                const ros::Time& stamp) const
{
  if (params_.ground_frame.empty())
  {
    return params_.ground_height;
  }
  const Eigen::Isometry3d grid_from_ground =
      tf2::transformToEigen(tf.lookupTransform(grid_frame, params_.ground_frame, stamp));
  return (grid_from_ground * Eigen::Vector3d(0.0, 0.0, params_.ground_height)).z();
}

ProjectedGrid::Ptr ProjectionStage::project(const DynamicGrid& grid, const sensor_msgs::CameraInfo& info,
                                            const tf2::BufferCore& tf, ProjectionNotes* notes,
                                            double grid_interval) const
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
  ProjectionNotes local_notes;
  ProjectionNotes& said = notes ? *notes : local_notes;
  said = ProjectionNotes();
  const ros::Time& image_stamp = info.header.stamp;
  const double grid_age = (image_stamp - grid.header.stamp).toSec();
  const double max_age = maxGridAge(grid_interval);
  if (std::abs(grid_age) > max_age)
  {
    said.cells_left_out =
        "the latest grid (t=" + std::to_string(grid.header.stamp.toSec()) + ") is " +
        std::to_string(grid_age) + " s away from the image, more than max_grid_age " +
        std::to_string(params_.max_grid_age) + " s" +
        (max_age > params_.max_grid_age ? " and " + std::to_string(kGridIntervalsOfAge) +
                                              " grid intervals (" + std::to_string(max_age) + " s)"
                                        : std::string());
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
    geometry.ground_z = groundZ(tf, grid.header.frame_id, image_stamp);
  }
  catch (const tf2::TransformException& e)
  {
    throw ProjectionSkipped("no tf " + grid.header.frame_id + " <- " + params_.ground_frame +
                            " (ground_frame): " + e.what());
  }
  ProjectedCells cells;
  if (said.cells_left_out.empty())
  {
    try
    {
      cells = projectGrid(gridCellsViewOf(grid), *camera, geometry, params_.projection);
    }
    catch (const std::invalid_argument& e)
    {
      throw ProjectionSkipped(std::string("cannot project the grid: ") + e.what());
    }
    said.invalid_cells = cells.cells_invalid;
  }
  ProjectedGrid::Ptr msg = projectedGridToMsg(std::move(cells), info.header, grid.header, *camera);
  const Eigen::Vector3d camera_position = geometry.camera_from_grid.inverse().translation();
  msg->camera_position.x = camera_position.x();
  msg->camera_position.y = camera_position.y();
  msg->camera_position.z = camera_position.z();
  const Eigen::Matrix<double, 3, 4> grid_to_image = camera->projection() * geometry.camera_from_grid.matrix();
  for (int r = 0; r < 3; ++r)
  {
    for (int c = 0; c < 4; ++c)
    {
      msg->grid_to_image[static_cast<std::size_t>(4 * r + c)] = grid_to_image(r, c);
    }
  }
  msg->ground_z = static_cast<float>(geometry.ground_z);
  return msg;
}

}  // namespace grid_vision_fusion
