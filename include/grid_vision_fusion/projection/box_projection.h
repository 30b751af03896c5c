// The image box of a 3-D box: the corners of an oriented box standing on a plane, and their
// projection through a rectified camera into an axis-aligned box clipped to the image, with its
// truncation. Shared by the KITTI ground truth (tracklets) and the simulator's labels.
#pragma once

#include <Eigen/Geometry>

#include <array>

#include "grid_vision_fusion/types.h"

namespace grid_vision_fusion
{
/// The 8 corners of a box whose bottom face is centred at `bottom_center` [m], turned by `yaw`
/// [rad] about +z (its length along the turned x axis): bottom 4 counter-clockwise from
/// front-left, then the top 4 in the same order.
std::array<Eigen::Vector3d, 8> orientedBoxCorners(const Eigen::Vector3d& bottom_center, double yaw,
                                                  double length, double width, double height);

/// A box projected into an image.
struct ImageBox
{
  bool in_view = false;     ///< some part projects into the image in front of the near plane
  BoundingBox box;          ///< projection of the 3-D box, clipped to the image [px]
  double truncation = 0.0;  ///< 1 − clipped area / unclipped area of the projected box, [0, 1]
};

/// Projects the box of `corners` (in the frame of `projection`, e.g. the rectified camera frame;
/// ordered as orientedBoxCorners()) with the 3×4 matrix `projection`: its edges are clipped
/// against the plane at depth `near_m` [m], the projected box is clipped to the `width` ×
/// `height` image. `in_view` is false when nothing of it lies in the image.
ImageBox projectBoxCorners(const std::array<Eigen::Vector3d, 8>& corners,
                           const Eigen::Matrix<double, 3, 4>& projection, int width, int height,
                           double near_m);

}  // namespace grid_vision_fusion
