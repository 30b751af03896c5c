#include "grid_vision_fusion/simulation/synthetic_camera.h"

#include <algorithm>
#include <array>
#include <cmath>

#include "grid_vision_fusion/projection/box_projection.h"

namespace grid_vision_fusion
{
namespace
{
const Eigen::Vector3d kLight = Eigen::Vector3d(0.4, 0.6, 0.9).normalized();
const cv::Vec3d kSkyTop(225.0, 170.0, 110.0);  // BGR
const cv::Vec3d kSkyHorizon(245.0, 225.0, 205.0);
const cv::Vec3d kAsphalt(95.0, 95.0, 100.0);
const cv::Vec3d kPaint(235.0, 235.0, 235.0);
const cv::Vec3d kSidewalk(150.0, 160.0, 165.0);
constexpr double kHazeDistanceM = 180.0;
constexpr double kLineHalfWidthM = 0.08;
constexpr double kDashLengthM = 3.0;
constexpr double kDashPeriodM = 9.0;
constexpr double kWindowFraction = 0.6;  // box actors: above this fraction of their height, glass

/// 0xRRGGBB → OpenCV's BGR order.
cv::Vec3d toVec(std::uint32_t rgb)
{
  return {static_cast<double>(rgb & 0xFF), static_cast<double>((rgb >> 8) & 0xFF),
          static_cast<double>((rgb >> 16) & 0xFF)};
}

cv::Vec3d roadColor(const Eigen::Vector3d& p, const RoadStyle& road)
{
  const double lateral = p.y() - road.center_y;
  if (std::abs(lateral) > road.half_width)
  {
    return kSidewalk;
  }
  if (std::abs(std::abs(lateral) - road.half_width) < 2 * kLineHalfWidthM)
  {
    return kPaint;  // edge lines
  }
  const double lane = lateral / road.lane_width;
  const double offset = std::abs(lane - std::round(lane)) * road.lane_width;
  const double along = std::fmod(std::fmod(p.x(), kDashPeriodM) + kDashPeriodM, kDashPeriodM);
  if (offset < kLineHalfWidthM && along < kDashLengthM)
  {
    return kPaint;
  }
  return kAsphalt;
}

double shade(const Eigen::Vector3d& normal)
{
  return 0.35 + 0.65 * std::max(0.0, normal.dot(kLight));
}

}  // namespace

int ActorInImage::occlusionLevel() const
{
  if (silhouette_pixels <= 0 || visible_pixels <= 0)
  {
    return 3;
  }
  const double visible = static_cast<double>(visible_pixels) / silhouette_pixels;
  return visible >= 0.8 ? 0 : visible >= 0.4 ? 1 : 2;
}

ActorInImage projectBox(const GroundBox& box, const Eigen::Isometry3d& world_from_projection,
                        const SyntheticCameraModel& camera)
{
  const Eigen::Isometry3d projection_from_world = world_from_projection.inverse();
  std::array<Eigen::Vector3d, 8> corners = orientedBoxCorners(
      Eigen::Vector3d(box.pose.x, box.pose.y, box.base_z), box.pose.yaw, box.length, box.width, box.height);
  for (Eigen::Vector3d& c : corners)
  {
    c = projection_from_world * c;
  }
  const ImageBox projected =
      projectBoxCorners(corners, camera.projection, camera.width, camera.height, camera.near_m);
  ActorInImage result;
  result.in_view = projected.in_view;
  result.box = projected.box;
  result.truncation = projected.truncation;
  return result;
}

RenderedImage renderCamera(const SceneSnapshot& scene, const std::vector<std::uint32_t>& colors_rgb,
                           const std::vector<std::uint32_t>& scenery_colors_rgb,
                           const Eigen::Isometry3d& world_from_projection, const SyntheticCameraModel& camera,
                           const RoadStyle& road)
{
  RenderedImage out;
  out.bgr.create(camera.height, camera.width, CV_8UC3);
  out.object_id.create(camera.height, camera.width, CV_32SC1);
  const std::size_t actor_count = scene.actorBoxes().size();
  out.actors.resize(actor_count);
  for (std::size_t i = 0; i < actor_count; ++i)
  {
    if (scene.actorActive(i))
    {
      out.actors[i] = projectBox(scene.actorBoxes()[i], world_from_projection, camera);
    }
  }

  const Eigen::Matrix3d m_inverse = camera.projection.leftCols<3>().inverse();
  const Eigen::Vector3d centre = world_from_projection * (-m_inverse * camera.projection.col(3));
  const Eigen::Matrix3d to_world = world_from_projection.linear() * m_inverse;
  std::vector<int> along;
  for (int v = 0; v < camera.height; ++v)
  {
    const double sky_mix = std::clamp(static_cast<double>(v) / (0.5 * camera.height), 0.0, 1.0);
    const cv::Vec3d sky = (1.0 - sky_mix) * kSkyTop + sky_mix * kSkyHorizon;
    auto* pixel = out.bgr.ptr<cv::Vec3b>(v);
    auto* id = out.object_id.ptr<std::int32_t>(v);
    for (int u = 0; u < camera.width; ++u)
    {
      const Eigen::Vector3d direction = (to_world * Eigen::Vector3d(u, v, 1.0)).normalized();
      const RayHit hit = scene.cast(centre, direction, camera.near_m, camera.far_m);
      cv::Vec3d color = sky;
      id[u] = -1;
      if (hit.object == RayHit::kGround)
      {
        color = roadColor(centre + hit.range * direction, road);
      }
      else if (hit.object >= RayHit::kSceneryBase)
      {
        const auto index = static_cast<std::size_t>(hit.object - RayHit::kSceneryBase);
        color = toVec(index < scenery_colors_rgb.size() ? scenery_colors_rgb[index] : 0x808080U) *
                shade(hit.normal);
      }
      else if (hit.hit())
      {
        const auto index = static_cast<std::size_t>(hit.object);
        color = toVec(index < colors_rgb.size() ? colors_rgb[index] : 0x2E5FA8U) * shade(hit.normal);
        const GroundBox& box = scene.actorBoxes()[index];
        // A profile's windows are its own surfaces (opaque to the camera); a box is glass above
        // kWindowFraction of its height.
        const double z = (centre + hit.range * direction).z() - box.base_z;
        if (box.shape != VehicleShape::kBox
                ? hit.glass
                : z > kWindowFraction * box.height && std::abs(hit.normal.z()) < 0.5)
        {
          color = 0.35 * color + cv::Vec3d(60.0, 45.0, 35.0);  // glass
        }
        id[u] = hit.object;
        ++out.actors[index].visible_pixels;
      }
      if (hit.hit())
      {
        const double haze = 1.0 - std::exp(-hit.range / kHazeDistanceM);
        color = (1.0 - haze) * color + haze * kSkyHorizon;
      }
      along.clear();
      scene.actorsAlong(centre, direction, camera.near_m, camera.far_m, along);
      for (int a : along)
      {
        ++out.actors[static_cast<std::size_t>(a)].silhouette_pixels;
      }
      pixel[u] = cv::Vec3b(cv::saturate_cast<uchar>(color[0]), cv::saturate_cast<uchar>(color[1]),
                           cv::saturate_cast<uchar>(color[2]));
    }
  }
  return out;
}

}  // namespace grid_vision_fusion
