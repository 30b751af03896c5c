#include "grid_vision_fusion/projection/box_projection.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace grid_vision_fusion
{
std::array<Eigen::Vector3d, 8> orientedBoxCorners(const Eigen::Vector3d& bottom_center, double yaw,
                                                  double length, double width, double height)
{
  const double c = std::cos(yaw);
  const double s = std::sin(yaw);
  const double hl = length / 2.0;
  const double hw = width / 2.0;
  const double local[4][2] = {{hl, hw}, {-hl, hw}, {-hl, -hw}, {hl, -hw}};
  std::array<Eigen::Vector3d, 8> out;
  std::size_t k = 0;
  for (double z : {0.0, height})
  {
    for (const auto& xy : local)
    {
      out[k++] = bottom_center + Eigen::Vector3d(c * xy[0] - s * xy[1], s * xy[0] + c * xy[1], z);
    }
  }
  return out;
}

ImageBox projectBoxCorners(const std::array<Eigen::Vector3d, 8>& corners,
                           const Eigen::Matrix<double, 3, 4>& projection, int width, int height,
                           double near_m)
{
  static const int kEdges[12][2] = {{0, 1}, {1, 2}, {2, 3}, {3, 0}, {4, 5}, {5, 6},
                                    {6, 7}, {7, 4}, {0, 4}, {1, 5}, {2, 6}, {3, 7}};
  const auto project = [&](const Eigen::Vector3d& x) -> Eigen::Vector3d
  { return projection.leftCols<3>() * x + projection.col(3); };
  double u_min = std::numeric_limits<double>::infinity(), v_min = u_min;
  double u_max = -u_min, v_max = -u_min;
  bool any = false;
  auto add = [&](const Eigen::Vector3d& x)
  {
    const Eigen::Vector3d h = project(x);
    const double u = h.x() / h.z();
    const double v = h.y() / h.z();
    u_min = std::min(u_min, u);
    u_max = std::max(u_max, u);
    v_min = std::min(v_min, v);
    v_max = std::max(v_max, v);
    any = true;
  };
  for (const auto& edge : kEdges)
  {
    const Eigen::Vector3d& a = corners[static_cast<std::size_t>(edge[0])];
    const Eigen::Vector3d& b = corners[static_cast<std::size_t>(edge[1])];
    const double wa = project(a).z();
    const double wb = project(b).z();
    if (wa >= near_m)
    {
      add(a);
    }
    if (wb >= near_m)
    {
      add(b);
    }
    if ((wa - near_m) * (wb - near_m) < 0.0)
    {
      add(a + (near_m - wa) / (wb - wa) * (b - a));
    }
  }
  ImageBox result;
  if (!any)
  {
    return result;
  }
  const double cu_min = std::clamp(u_min, 0.0, width - 1.0);
  const double cu_max = std::clamp(u_max, 0.0, width - 1.0);
  const double cv_min = std::clamp(v_min, 0.0, height - 1.0);
  const double cv_max = std::clamp(v_max, 0.0, height - 1.0);
  const double full_area = (u_max - u_min) * (v_max - v_min);
  const double clipped_area = (cu_max - cu_min) * (cv_max - cv_min);
  result.in_view = clipped_area > 0.0;
  result.box = BoundingBox{static_cast<float>(cu_min), static_cast<float>(cv_min), static_cast<float>(cu_max),
                           static_cast<float>(cv_max)};
  result.truncation = full_area > 0.0 ? std::clamp(1.0 - clipped_area / full_area, 0.0, 1.0) : 1.0;
  return result;
}

}  // namespace grid_vision_fusion
