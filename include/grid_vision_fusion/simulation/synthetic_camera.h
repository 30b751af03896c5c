// A ray-casting camera for the synthetic world: shaded box faces (or vehicle profiles, their
// windows opaque) in depth order over the ground (a road) and a sky, an object-id buffer, and
// per-actor 2-D boxes, truncation and occlusion for labels.
#pragma once

#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include <vector>

#include "grid_vision_fusion/simulation/synthetic_world.h"
#include "grid_vision_fusion/types.h"

namespace grid_vision_fusion
{
/// A rectified pinhole camera: 3×4 projection matrix P = [M | p4] of its image (the frame of P is
/// the "projection frame", for KITTI the rectified camera-0 frame) and the image size.
struct SyntheticCameraModel
{
  Eigen::Matrix<double, 3, 4> projection = Eigen::Matrix<double, 3, 4>::Zero();
  int width = 1242;
  int height = 375;
  double near_m = 0.5;   ///< surfaces closer than this along the ray are not drawn [m]
  double far_m = 200.0;  ///< [m]
};

/// How the road is painted: a straight road along world x.
struct RoadStyle
{
  double center_y = 0.0;    ///< world y of the centre line [m]
  double half_width = 7.0;  ///< asphalt from center_y − half_width to center_y + half_width [m]
  double lane_width = 3.5;  ///< dashed lane lines every lane_width from the centre [m]
};

/// Label geometry of one actor in one image.
struct ActorInImage
{
  bool in_view = false;       ///< some part projects into the image in front of the camera
  BoundingBox box;            ///< projection of the 3-D box, clipped to the image [px]
  double truncation = 0.0;    ///< 1 − clipped area / unclipped area of the projected box, [0, 1]
  int silhouette_pixels = 0;  ///< pixels whose ray passes through the actor
  int visible_pixels = 0;     ///< pixels where the actor is the nearest surface
  /// KITTI occlusion level from visible / silhouette: ≥ 0.8 → 0, ≥ 0.4 → 1, > 0 → 2, else 3.
  int occlusionLevel() const;
};

/// One rendered image with its buffers.
struct RenderedImage
{
  cv::Mat bgr;                       ///< CV_8UC3
  cv::Mat object_id;                 ///< CV_32SC1: actor index, or −1 for ground, scenery and sky
  std::vector<ActorInImage> actors;  ///< one per actor of the snapshot
};

/// Renders `scene` as seen by `camera`, whose projection frame is placed in the world by
/// `world_from_projection`. `colors_rgb` gives the body colour of every actor (0xRRGGBB) and
/// `scenery_colors_rgb` of every scenery box.
RenderedImage renderCamera(const SceneSnapshot& scene, const std::vector<std::uint32_t>& colors_rgb,
                           const std::vector<std::uint32_t>& scenery_colors_rgb,
                           const Eigen::Isometry3d& world_from_projection, const SyntheticCameraModel& camera,
                           const RoadStyle& road = RoadStyle{});

/// The image box of `box` (clipped against the near plane, then to the image) and its
/// truncation. `in_view` is false when nothing of it projects into the image.
ActorInImage projectBox(const GroundBox& box, const Eigen::Isometry3d& world_from_projection,
                        const SyntheticCameraModel& camera);

}  // namespace grid_vision_fusion
