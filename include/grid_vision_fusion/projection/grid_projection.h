// Projection of the dynamic occupancy grid into a camera image (Gómez et al., §III-C): the
// occupied cells become the "static/dynamic points" the fusion regions collect.
#pragma once

#include <Eigen/Geometry>

#include <cstddef>
#include <cstdint>
#include <vector>

#include "grid_vision_fusion/types.h"

namespace grid_vision_fusion
{
/// Read-only view of the per-cell arrays of a dynamic occupancy grid, laid out as
/// DynamicGrid.msg: row-major, index = row · width + col, rows along +y of the grid frame,
/// columns along +x, axes aligned with the frame; cell (row, col) covers
/// [origin_x + col·res, origin_x + (col+1)·res) × [origin_y + row·res, origin_y + (row+1)·res).
/// It borrows the arrays (e.g. those of a DynamicGrid message) and copies nothing.
struct GridCellsView
{
  std::uint32_t width = 0;           ///< cells along +x
  std::uint32_t height = 0;          ///< cells along +y
  double resolution = 0.0;           ///< cell edge [m]
  double origin_x = 0.0;             ///< x of the corner of cell (0, 0) in the grid frame [m]
  double origin_y = 0.0;             ///< y of the corner of cell (0, 0) in the grid frame [m]
  const float* p_static = nullptr;   ///< P(static occupied) per cell, [0, 1]
  const float* p_dynamic = nullptr;  ///< P(dynamic occupied) per cell, [0, 1]
  const float* vx = nullptr;         ///< mean velocity along +x given dynamic [m/s], grid frame
  const float* vy = nullptr;         ///< mean velocity along +y given dynamic [m/s], grid frame
  /// Variance of vx and of vy given dynamic [m²/s²]; optional (nullptr: no Mahalanobis test,
  /// see GridProjectionConfig::mahalanobis_threshold).
  const float* v_var_x = nullptr;
  const float* v_var_y = nullptr;
  /// Scans since each cell last held obstacle points (DynamicGridFilter::scansSinceHit());
  /// optional (nullptr: every cell counts as seen in the grid's scan).
  const std::uint8_t* scans_since_hit = nullptr;
  /// z of the ground under each cell in the grid frame [m], as the scan shows it
  /// (DynamicGridFilter::cellGroundHeights()); optional (nullptr, or NaN in a cell: the
  /// ProjectionGeometry's ground plane).
  const float* ground_z = nullptr;

  std::size_t size() const { return static_cast<std::size_t>(width) * height; }
  /// @throws std::invalid_argument when the resolution is not finite and > 0, the origin is not
  ///         finite, or an array pointer is null while the grid has cells.
  void validate() const;
};

/// Pinhole model of a rectified camera given by its 3×4 projection matrix P (the P of a
/// sensor_msgs/CameraInfo, or a KITTI P_rect): a point X of the rectified camera frame (x right,
/// y down, z forward) lands on w·(u, v, 1)ᵀ = P·(X, 1)ᵀ, with depth w along the optical axis.
/// This is image_geometry's PinholeCameraModel::project3dToPixel() plus the P(2,3) term that
/// KITTI's colour cameras carry (a shift of the optical centre along the axis; 0 in ROS).
class PinholeCamera
{
public:
  /// @throws std::invalid_argument when P is not finite, its focal lengths P(0,0), P(1,1) are
  ///         not > 0 ("zero focal length": an uncalibrated camera), its last row is not
  ///         (0, 0, 1, t), or width/height is 0.
  PinholeCamera(const Eigen::Matrix<double, 3, 4>& projection, std::uint32_t width, std::uint32_t height);

  const Eigen::Matrix<double, 3, 4>& projection() const { return projection_; }
  std::uint32_t width() const { return width_; }
  std::uint32_t height() const { return height_; }

  /// Projects `point` (rectified camera frame [m]). Returns false (pixel untouched) when its depth
  /// w is not > 0. `depth` receives w [m].
  bool project(const Eigen::Vector3d& point, Eigen::Vector2d& pixel, double& depth) const;
  /// Whether pixel (u, v) lies in [0, width) × [0, height) (pixel centres at integers, as OpenCV).
  bool inImage(double u, double v) const { return u >= 0.0 && v >= 0.0 && u < width_ && v < height_; }

private:
  Eigen::Matrix<double, 3, 4> projection_;
  std::uint32_t width_;
  std::uint32_t height_;
};

/// Parameters of the grid projection.
struct GridProjectionConfig
{
  /// A cell is projected when P(S) ≥ this or P(D) ≥ this. Range (0, 1].
  double occupied_threshold = 0.4;
  /// State of a projected cell: DYNAMIC when P(D) > dynamic_ratio · (P(S) + P(D)), i.e. when the
  /// dynamic share of its occupied mass exceeds the ratio; STATIC otherwise (ties are static: an
  /// even split is no evidence of motion). 0.5 = "P(D) > P(S)". Range [0, 1).
  double dynamic_ratio = 0.5;
  /// Velocity test of a DYNAMIC cell (the grid's own classification, Nuss et al. 2018): a cell
  /// whose mass says DYNAMIC stays DYNAMIC only when its mean velocity is at least this fast
  /// [m/s]; otherwise it is STATIC (a stopped object keeps dynamic mass while its particles slow
  /// down). 0 disables the test (the paper's rule: the masses alone). Range >= 0.
  double min_dynamic_speed = 1.0;
  /// Mahalanobis test of a DYNAMIC cell: vx²/var_x + vy²/var_y must reach this (4: the velocity
  /// is two standard deviations away from zero), otherwise STATIC. 0 disables it; it also needs
  /// the variances in the GridCellsView. Range >= 0.
  double mahalanobis_threshold = 0.0;
  /// Minimum depth along the optical axis [m]; nearer points (and those behind the camera) are
  /// dropped. Range > 0.
  double min_depth = 0.5;
  /// Column mode: each cell also projects above its ground point, up to column_height, giving
  /// near objects more points in their fusion region. Off: the ground point only.
  bool column_mode = false;
  /// Height of the top of a column above the ground plane [m]. Range > 0.
  double column_height = 1.5;
  /// Points per column, evenly spaced from the ground point to the top (both included). >= 2.
  int column_points = 2;
  /// A cell whose ground point lies below the image (nearer than the camera sees the road, about
  /// 6 m for KITTI's colour cameras) projects at the lowest point of its column, up to
  /// column_height, that the image shows — on its bottom row —, so the near part of a close
  /// object stays in the fusion band of its box, which the image's edge cuts. Off: such cells
  /// are dropped (the paper's ground points only). Applies to the ground point of every mode.
  bool near_cells_at_bottom = true;
  /// Each cell's ground point at the ground the grid carries for it (GridCellsView::ground_z, the
  /// scan's own ground under the cell), where it has one; else, and when false, at the
  /// ProjectionGeometry's ground plane. A road's camber, slope or raised verge, or the vehicle's
  /// roll, then no longer lifts an object's cells out of the fusion band of its box.
  bool ground_from_grid = true;
  /// Predict the position of DYNAMIC cells to the image stamp with their velocity:
  /// (x, y) += (vx, vy)·(t_image − t_grid). STATIC cells do not move.
  bool predict_to_image_stamp = true;

  /// @throws std::invalid_argument naming the first bad field.
  void validate() const;
};

/// Where and when to project: the per-image inputs that come from tf and the stamps.
struct ProjectionGeometry
{
  /// camera (rectified optical frame) ← grid frame, at the image stamp.
  Eigen::Isometry3d camera_from_grid = Eigen::Isometry3d::Identity();
  /// z of the ground plane in the grid frame [m]: where the cells' ground points lie, unless the
  /// grid carries each cell's ground (GridCellsView::ground_z) and GridProjectionConfig::
  /// ground_from_grid says to use it.
  double ground_z = 0.0;
  /// t_image − t_grid [s]; used when GridProjectionConfig::predict_to_image_stamp.
  double time_offset = 0.0;
};

/// Owning structure-of-arrays output, one element per projected point, as ProjectedGrid.msg.
/// The vectors can be moved into the message without a copy.
struct ProjectedCells
{
  std::vector<float> u, v, depth, x, y, vx, vy, p_static, p_dynamic;
  std::vector<std::uint8_t> state;  ///< CellState values
  /// Per point, the cell's scans since it last held obstacle points; empty without
  /// GridCellsView::scans_since_hit.
  std::vector<std::uint8_t> scans_since_hit;
  /// Per point, the variances of the cell's velocity given dynamic [m²/s²]; empty without
  /// GridCellsView::v_var_x and v_var_y.
  std::vector<float> v_var_x, v_var_y;
  /// The grid's cell size [m]: the lattice step of x and y (of static cells; dynamic cells are
  /// moved to the image stamp).
  double resolution = 0.0;

  std::size_t cells_selected = 0;  ///< cells that passed the occupancy threshold
  std::size_t cells_invalid =
      0;  ///< cells skipped: NaN/Inf probability, or NaN/Inf velocity of a dynamic cell
  std::size_t points_behind = 0;   ///< points dropped with depth < min_depth
  std::size_t points_outside = 0;  ///< points dropped outside the image

  std::size_t size() const { return u.size(); }
  /// Reserves room for `points` points in every array.
  void reserve(std::size_t points);
  /// A view for fuse() and drawProjectedPoints(); valid while this object is unchanged.
  ProjectedPointsView view() const;
};

/// The state of a cell with occupancy masses `p_static`, `p_dynamic`, per config.dynamic_ratio.
inline CellState cellState(float p_static, float p_dynamic, const GridProjectionConfig& config)
{
  return p_dynamic > config.dynamic_ratio * (static_cast<double>(p_static) + p_dynamic) ? CellState::kDynamic
                                                                                        : CellState::kStatic;
}

/// The state of a cell from its masses (cellState() above) and its velocity: DYNAMIC only when
/// the masses say so, |(vx, vy)| >= config.min_dynamic_speed [m/s] and, when
/// config.mahalanobis_threshold > 0 and the variances are given (var_x, var_y >= 0 [m²/s²];
/// pass a negative value when unknown), vx²/var_x + vy²/var_y >= config.mahalanobis_threshold.
CellState cellState(float p_static, float p_dynamic, float vx, float vy, float var_x, float var_y,
                    const GridProjectionConfig& config);

/// Projects the occupied cells of `grid` into `camera`: selects the cells (occupied_threshold),
/// decides their state, predicts dynamic cells to the image stamp, projects the ground point
/// (cell centre at z = geometry.ground_z; plus the column points in column mode), drops points
/// nearer than min_depth or outside the image. x, y of the output are the (predicted) cell
/// centre in the grid frame; vx, vy the grid velocity (0 for a static cell with NaN velocity).
/// @throws std::invalid_argument when `grid` is invalid (GridCellsView::validate()), `config`
///         is invalid, or geometry holds a non-finite value.
ProjectedCells projectGrid(const GridCellsView& grid, const PinholeCamera& camera,
                           const ProjectionGeometry& geometry, const GridProjectionConfig& config);

}  // namespace grid_vision_fusion
