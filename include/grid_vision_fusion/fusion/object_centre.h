// Object centres from the grid cells of a fusion region: the lidar sees the faces of an object
// that look at the sensor, so the median of the cells lies on the near face, about half a vehicle
// length from the centre. The estimate here picks the object's cells among the region's, fits
// the orientation of their outline, and completes the class's typical footprint away from the
// camera (or takes the extent of the cells where they cover more than the footprint).
#pragma once

#include <Eigen/Core>

#include <cstddef>
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "grid_vision_fusion/types.h"

namespace grid_vision_fusion
{
/// The typical ground footprint of an object class.
struct Footprint
{
  double length = 0.0;  ///< along the object's heading [m], > 0
  double width = 0.0;   ///< across it [m], > 0
};

/// Parameters of the centre estimate.
struct CentreConfig
{
  /// Cells nearer than this to each other belong to the same cluster (single linkage) [m], > 0.
  /// Grid cells of one object touch (0.2 m grid), objects in a row are rarely this close.
  double cluster_distance = 0.5;
  /// When the cells of the object's cluster cover more than its footprint along an axis, those
  /// whose last lidar hit is older than this many scans (ProjectedPointsView::scans_since_hit)
  /// are left out of its centre, as long as kMinFreshCentreCells remain: the grid keeps the
  /// occupancy of the cells an object has left where the lidar cannot see them (behind the next
  /// car of a queue), and this trail drags the centre behind a slow object. Cells that fit the
  /// footprint all count (a parked car's parts hidden now are still where it is). -1: every cell
  /// of the cluster. In [-1, 254].
  int max_scans_since_hit = 0;
  /// Footprint per detector label (lower case, as published). The defaults are the mean
  /// dimensions of the KITTI object benchmark's classes; a label without an entry gets the
  /// extent of its cells only (no completion).
  std::map<std::string, Footprint> footprints{
      {"car", {3.9, 1.6}},        {"van", {5.1, 1.9}},     {"truck", {10.1, 2.6}},
      {"pedestrian", {0.8, 0.7}}, {"cyclist", {1.8, 0.6}}, {"person_sitting", {0.8, 0.6}},
      {"tram", {16.1, 2.5}},      {"misc", {3.6, 1.5}},
  };

  /// @throws std::invalid_argument naming the first bad field (max_scans_since_hit outside
  ///         [-1, 254], cluster_distance not finite or
  ///         <= 0, a footprint dimension not finite or <= 0, an empty label).
  void validate() const;
};

/// Fewest recently hit cells (CentreConfig::max_scans_since_hit) that make a centre on their own.
constexpr std::size_t kMinFreshCentreCells = 3;

/// An object centre estimate.
struct CentreEstimate
{
  double x = 0.0;    ///< centre x [m], frame of the points
  double y = 0.0;    ///< centre y [m]
  double yaw = 0.0;  ///< orientation of the fitted outline's first axis, [0, π/2) [rad]
  /// The object's length [m]: its footprint's, or the cells' extent along the footprint's length
  /// axis where they cover more (without a footprint: their larger extent). Where the object's
  /// view is cut, its visible part, and the centre with it, may lie anywhere along it.
  double length = 0.0;
};

/// Orientation in [0, π/2) of the rectangle that fits the 2-D points (x[i], y[i]) best by the
/// closeness criterion of search-based L-shape fitting (Zhang et al., "Efficient L-Shape Fitting
/// for Vehicle Detection Using Laser Scanners", IV 2017): every point counts 1/d, d its distance
/// to the nearest edge of the bounding rectangle at that orientation (at least 0.05 m). A coarse
/// search in 9° steps, then 1° steps within ±4° of the best. 0 for fewer than 3 points [rad].
double fitOrientation(const std::vector<double>& x, const std::vector<double>& y);

/// The cells of `members` (indices into `points`) that belong to the object whose box is `box`:
/// the members are clustered by single linkage at `cluster_distance`, and the object's cluster is
/// the one with the most cells near the box's bottom edge in the image, where the object meets
/// the ground. A cell projected below the bottom edge (v > y_max + 10 % of the box height h: the
/// margin of a trained detector's bottom edge) is nearer than the object's nearest ground point:
/// it belongs to an object in front. A cell projected higher than y_max − 10 % of h lies behind
/// the object's near face: the walls, parked cars and kerbs that the band collects around a
/// small object. Such cells count less the farther out they lie (Gaussian, σ = 10 % of h).
/// The bottom edge is where the object's nearest part meets the ground: a cluster's score is
/// also multiplied by exp(−z²/2), z the distance of its lowest-projected cell above y_max in
/// units of a trained detector's bottom-edge error (4.7 % of h; below y_max, in units of 10 % of
/// h beyond the 10 % margin): a wall with more cells than the pedestrian in front of it loses.
/// With `expected` (the cells the object's track had in the last image, moved on by its
/// velocity; empty: none), a cluster's score is multiplied by one plus the share of its cells
/// within cluster_distance of an expected cell: the object's own cells continue from image to
/// image, where a box edge that moves by a few pixels (a real detector's) tips the bottom-edge
/// score towards what stands behind or beside the object. Ties go to the cluster reaching lowest
/// in the image.
/// The indices keep the order of `members`; empty when `members` is.
/// @throws std::invalid_argument when `members` holds an index outside `points`.
std::vector<std::uint32_t> objectCluster(const ProjectedPointsView& points,
                                         const std::vector<std::uint32_t>& members, const BoundingBox& box,
                                         double cluster_distance,
                                         const std::vector<Eigen::Vector2d>& expected = {});

/// The centre of the object whose box is `box` from the region points `members` of `points`
/// (indices, non-empty), seen from `camera_x`, `camera_y` (the camera's optical centre in the
/// frame of the points [m]):
/// 1.–2. the object's cells are objectCluster() at config.cluster_distance;
/// 3. its orientation comes from fitOrientation();
/// 4. with a footprint, its length goes along the axis that explains the face seen most
///    squarely (the observed extent across the viewing direction matches one dimension), and
///    along each axis the centre lies half the dimension behind the face nearest the camera,
///    or midway between the cells where the camera looks along the other axis or the cells
///    cover more than the dimension; without one, the centre of the cells' extent.
/// @throws std::invalid_argument when `members` is empty or holds an index outside `points`.
CentreEstimate estimateCentre(const ProjectedPointsView& points, const std::vector<std::uint32_t>& members,
                              const BoundingBox& box, double camera_x, double camera_y,
                              const Footprint* footprint, const CentreConfig& config);

/// Steps 3.–4. of estimateCentre() on the object's cells `cluster` (indices into `points`,
/// non-empty), e.g. the cluster fuse() has found (FusedObject::cluster): on those of its cells
/// hit within `max_scans_since_hit` scans when its cells cover more than `footprint` along an
/// axis, points.scans_since_hit is given, the bound is >= 0 and at least kMinFreshCentreCells
/// are; on all of them otherwise (see CentreConfig::max_scans_since_hit).
/// @throws std::invalid_argument when `cluster` is empty.
CentreEstimate centreOfCluster(const ProjectedPointsView& points, const std::vector<std::uint32_t>& cluster,
                               double camera_x, double camera_y, const Footprint* footprint,
                               int max_scans_since_hit = -1);

}  // namespace grid_vision_fusion
