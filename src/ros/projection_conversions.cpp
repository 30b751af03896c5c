#include "grid_vision_fusion/ros/projection_conversions.h"

#include <boost/make_shared.hpp>

#include <array>
#include <cmath>
#include <sstream>
#include <stdexcept>
#include <utility>

namespace grid_vision_fusion
{
namespace
{
constexpr double kOrientationTolerance = 1e-6;
}  // namespace

std::string checkDynamicGrid(const DynamicGrid& msg)
{
  const std::size_t cells = static_cast<std::size_t>(msg.info.width) * msg.info.height;
  const std::pair<const char*, std::size_t> sizes[] = {{"p_static", msg.p_static.size()},
                                                       {"p_dynamic", msg.p_dynamic.size()},
                                                       {"vx", msg.vx.size()},
                                                       {"vy", msg.vy.size()}};
  for (const auto& [name, size] : sizes)
  {
    if (size != cells)
    {
      std::ostringstream error;
      error << "DynamicGrid array " << name << " has " << size
            << " elements, expected width*height = " << msg.info.width << "*" << msg.info.height << " = "
            << cells;
      return error.str();
    }
  }
  const std::array<std::pair<const char*, std::size_t>, 2> optional{
      {{"scans_since_hit", msg.scans_since_hit.size()}, {"ground_z", msg.ground_z.size()}}};
  for (const auto& [name, size] : optional)
  {
    if (size != 0 && size != cells)
    {
      return std::string("DynamicGrid array ") + name + " has " + std::to_string(size) +
             " elements, expected none or width*height = " + std::to_string(cells);
    }
  }
  if (!std::isfinite(msg.info.resolution) || !(msg.info.resolution > 0.F))
  {
    return "DynamicGrid info.resolution must be finite and > 0, got " + std::to_string(msg.info.resolution);
  }
  const auto& origin = msg.info.origin;
  if (!std::isfinite(origin.position.x) || !std::isfinite(origin.position.y))
  {
    return "DynamicGrid info.origin.position is not finite";
  }
  const auto& q = origin.orientation;
  // Identity up to sign; an all-zero quaternion (left unset) is read as the identity too.
  const bool identity = std::abs(q.x) < kOrientationTolerance && std::abs(q.y) < kOrientationTolerance &&
                        std::abs(q.z) < kOrientationTolerance;
  if (!identity)
  {
    return "DynamicGrid info.origin.orientation must be the identity (grid axes along the frame axes)";
  }
  return {};
}

GridCellsView gridCellsViewOf(const DynamicGrid& msg)
{
  GridCellsView view;
  view.width = msg.info.width;
  view.height = msg.info.height;
  view.resolution = msg.info.resolution;
  view.origin_x = msg.info.origin.position.x;
  view.origin_y = msg.info.origin.position.y;
  view.p_static = msg.p_static.data();
  view.p_dynamic = msg.p_dynamic.data();
  view.vx = msg.vx.data();
  view.vy = msg.vy.data();
  // The variances are optional (the Mahalanobis test of the projection is skipped without them).
  const std::size_t cells = view.size();
  if (msg.v_var_x.size() == cells && msg.v_var_y.size() == cells)
  {
    view.v_var_x = msg.v_var_x.data();
    view.v_var_y = msg.v_var_y.data();
  }
  if (msg.scans_since_hit.size() == cells)  // optional too
  {
    view.scans_since_hit = msg.scans_since_hit.data();
  }
  if (msg.ground_z.size() == cells)  // optional too
  {
    view.ground_z = msg.ground_z.data();
  }
  return view;
}

PinholeCamera pinholeFromCameraInfo(const sensor_msgs::CameraInfo& msg)
{
  bool all_zero = true;
  for (const double p : msg.P)
  {
    all_zero = all_zero && p == 0.0;
  }
  if (all_zero)
  {
    throw std::invalid_argument("CameraInfo P is missing (all zeros): the camera is not calibrated");
  }
  Eigen::Matrix<double, 3, 4> projection;
  for (int r = 0; r < 3; ++r)
  {
    for (int c = 0; c < 4; ++c)
    {
      projection(r, c) = msg.P[static_cast<std::size_t>(r * 4 + c)];
    }
  }
  try
  {
    return PinholeCamera(projection, msg.width, msg.height);
  }
  catch (const std::invalid_argument& e)
  {
    throw std::invalid_argument(std::string("CameraInfo: ") + e.what());
  }
}

ProjectedGrid::Ptr projectedGridToMsg(ProjectedCells&& cells, const std_msgs::Header& image_header,
                                      const std_msgs::Header& grid_header, const PinholeCamera& camera)
{
  auto msg = boost::make_shared<ProjectedGrid>();
  msg->header = image_header;
  msg->grid_stamp = grid_header.stamp;
  msg->grid_frame_id = grid_header.frame_id;
  msg->image_width = camera.width();
  msg->image_height = camera.height();
  msg->resolution = static_cast<float>(cells.resolution);
  msg->u = std::move(cells.u);
  msg->v = std::move(cells.v);
  msg->depth = std::move(cells.depth);
  msg->x = std::move(cells.x);
  msg->y = std::move(cells.y);
  msg->vx = std::move(cells.vx);
  msg->vy = std::move(cells.vy);
  msg->p_static = std::move(cells.p_static);
  msg->p_dynamic = std::move(cells.p_dynamic);
  msg->state = std::move(cells.state);
  msg->scans_since_hit = std::move(cells.scans_since_hit);
  msg->v_var_x = std::move(cells.v_var_x);
  msg->v_var_y = std::move(cells.v_var_y);
  return msg;
}

}  // namespace grid_vision_fusion
