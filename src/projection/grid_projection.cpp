#include "grid_vision_fusion/projection/grid_projection.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace grid_vision_fusion
{
namespace
{
void require(bool condition, const std::string& message)
{
  if (!condition)
  {
    throw std::invalid_argument(message);
  }
}

bool allFinite(const Eigen::Isometry3d& transform)
{
  return transform.matrix().allFinite();
}
}  // namespace

void GridCellsView::validate() const
{
  require(std::isfinite(resolution) && resolution > 0.0,
          "grid resolution must be finite and > 0 m, got " + std::to_string(resolution));
  require(std::isfinite(origin_x) && std::isfinite(origin_y), "grid origin must be finite");
  if (size() > 0)
  {
    require(p_static != nullptr && p_dynamic != nullptr && vx != nullptr && vy != nullptr,
            "grid of " + std::to_string(width) + "x" + std::to_string(height) +
                " cells lacks one of the arrays p_static, p_dynamic, vx, vy");
  }
}

PinholeCamera::PinholeCamera(const Eigen::Matrix<double, 3, 4>& projection, std::uint32_t width,
                             std::uint32_t height)
    : projection_(projection), width_(width), height_(height)
{
  require(projection.allFinite(), "camera projection matrix P holds NaN/Inf");
  require(projection(0, 0) > 0.0 && projection(1, 1) > 0.0,
          "camera projection matrix P has a zero or negative focal length (fx = P[0] = " +
              std::to_string(projection(0, 0)) + ", fy = P[5] = " + std::to_string(projection(1, 1)) +
              "): the camera is not calibrated");
  require(projection(2, 0) == 0.0 && projection(2, 1) == 0.0 && projection(2, 2) == 1.0,
          "camera projection matrix P is not that of a rectified pinhole camera: its last row must be "
          "(0, 0, 1, t)");
  require(width > 0 && height > 0,
          "camera image size must be > 0, got " + std::to_string(width) + "x" + std::to_string(height));
}

bool PinholeCamera::project(const Eigen::Vector3d& point, Eigen::Vector2d& pixel, double& depth) const
{
  const Eigen::Vector3d homogeneous = projection_ * point.homogeneous();
  depth = homogeneous.z();
  if (!(depth > 0.0))
  {
    return false;
  }
  pixel = homogeneous.head<2>() / depth;
  return true;
}

void GridProjectionConfig::validate() const
{
  require(occupied_threshold > 0.0 && occupied_threshold <= 1.0,
          "occupied_threshold must be in (0, 1], got " + std::to_string(occupied_threshold));
  require(dynamic_ratio >= 0.0 && dynamic_ratio < 1.0,
          "dynamic_ratio must be in [0, 1), got " + std::to_string(dynamic_ratio));
  require(std::isfinite(min_dynamic_speed) && min_dynamic_speed >= 0.0,
          "min_dynamic_speed must be finite and >= 0 m/s, got " + std::to_string(min_dynamic_speed));
  require(std::isfinite(mahalanobis_threshold) && mahalanobis_threshold >= 0.0,
          "mahalanobis_threshold must be finite and >= 0, got " + std::to_string(mahalanobis_threshold));
  require(std::isfinite(min_depth) && min_depth > 0.0,
          "min_depth must be finite and > 0 m, got " + std::to_string(min_depth));
  require(std::isfinite(column_height) && column_height > 0.0,
          "column_height must be finite and > 0 m, got " + std::to_string(column_height));
  require(column_points >= 2 && column_points <= 100,
          "column_points must be in [2, 100], got " + std::to_string(column_points));
}

CellState cellState(float p_static, float p_dynamic, float vx, float vy, float var_x, float var_y,
                    const GridProjectionConfig& config)
{
  if (cellState(p_static, p_dynamic, config) != CellState::kDynamic)
  {
    return CellState::kStatic;
  }
  const double speed2 = static_cast<double>(vx) * vx + static_cast<double>(vy) * vy;
  if (!(speed2 >= config.min_dynamic_speed * config.min_dynamic_speed))
  {
    return CellState::kStatic;
  }
  if (config.mahalanobis_threshold > 0.0 && var_x >= 0.0F && var_y >= 0.0F)
  {
    constexpr double kMinVariance = 1e-6;  // [m²/s²]: a particle cloud collapsed onto one velocity
    const double m2 = static_cast<double>(vx) * vx / std::max<double>(var_x, kMinVariance) +
                      static_cast<double>(vy) * vy / std::max<double>(var_y, kMinVariance);
    if (!(m2 >= config.mahalanobis_threshold))
    {
      return CellState::kStatic;
    }
  }
  return CellState::kDynamic;
}

void ProjectedCells::reserve(std::size_t points)
{
  for (std::vector<float>* array : {&u, &v, &depth, &x, &y, &vx, &vy, &p_static, &p_dynamic})
  {
    array->reserve(points);
  }
  state.reserve(points);
  scans_since_hit.reserve(points);
  v_var_x.reserve(points);
  v_var_y.reserve(points);
}

ProjectedPointsView ProjectedCells::view() const
{
  return pointsViewOf(*this);
}

namespace
{
/// The camera and the columns of one projection.
struct ColumnGeometry
{
  Eigen::Matrix<double, 3, 4> m;  ///< grid frame point → homogeneous pixel
  double ground_z = 0.0;          ///< z of the cells' ground points in the grid frame [m]
  int points_per_cell = 1;
  double column_step = 0.0;  ///< height between the points of a column [m]
  double width = 0.0;        ///< image width [px]
  double height = 0.0;       ///< image height [px]
};

/// A cell that passed the occupancy threshold: its masses, state, velocity and where it is at the
/// image stamp.
struct SelectedCell
{
  std::size_t index = 0;
  float p_static = 0.0F;
  float p_dynamic = 0.0F;
  CellState state = CellState::kStatic;
  float vx = 0.0F;
  float vy = 0.0F;
  double x = 0.0;  ///< ground point in the grid frame [m]
  double y = 0.0;
  double z = 0.0;
};

/// @throws std::invalid_argument when the grid, the config or the geometry is invalid.
void validateProjection(const GridCellsView& grid, const ProjectionGeometry& geometry,
                        const GridProjectionConfig& config)
{
  grid.validate();
  config.validate();
  require(allFinite(geometry.camera_from_grid), "camera ← grid transform holds NaN/Inf");
  require(std::isfinite(geometry.ground_z),
          "ground_z must be finite, got " + std::to_string(geometry.ground_z));
  require(std::isfinite(geometry.time_offset),
          "time offset between image and grid must be finite, got " + std::to_string(geometry.time_offset));
}

/// The cells at or above `threshold` in P(S) or P(D).
std::size_t candidateCells(const GridCellsView& grid, double threshold)
{
  std::size_t candidates = 0;
  for (std::size_t i = 0; i < grid.size(); ++i)
  {
    candidates += (grid.p_static[i] >= threshold || grid.p_dynamic[i] >= threshold) ? 1 : 0;
  }
  return candidates;
}

/// The state and velocity of `cell` (masses set) and its ground point (x, y) moved to the image
/// stamp (dt after the grid) when DYNAMIC; false when a DYNAMIC cell has no finite velocity.
bool moveToImageStamp(const GridCellsView& grid, const GridProjectionConfig& config, double dt, double x,
                      double y, SelectedCell& cell)
{
  const std::size_t i = cell.index;
  const float ps = cell.p_static;
  const float pd = cell.p_dynamic;
  float cvx = grid.vx[i];
  float cvy = grid.vy[i];
  // A cell dynamic by its masses needs a finite velocity (else it is invalid, below); then the
  // velocity test may still make it static.
  CellState state = cellState(ps, pd, config);
  if (state == CellState::kDynamic && std::isfinite(cvx) && std::isfinite(cvy))
  {
    const bool variances = grid.v_var_x != nullptr && grid.v_var_y != nullptr;
    state = cellState(ps, pd, cvx, cvy, variances ? grid.v_var_x[i] : -1.0F,
                      variances ? grid.v_var_y[i] : -1.0F, config);
  }
  if (state == CellState::kDynamic)
  {
    if (!std::isfinite(cvx) || !std::isfinite(cvy))
    {
      return false;
    }
    x += cvx * dt;
    y += cvy * dt;
  }
  else if (!std::isfinite(cvx) || !std::isfinite(cvy))
  {
    cvx = 0.F;
    cvy = 0.F;
  }
  cell.state = state;
  cell.vx = cvx;
  cell.vy = cvy;
  cell.x = x;
  cell.y = y;
  return true;
}

/// Appends the point (pu, pv) at `depth` of `cell` to `out`.
void appendPoint(const GridCellsView& grid, const SelectedCell& cell, double pu, double pv, double depth,
                 ProjectedCells& out)
{
  const std::size_t i = cell.index;
  out.u.push_back(static_cast<float>(pu));
  out.v.push_back(static_cast<float>(pv));
  out.depth.push_back(static_cast<float>(depth));
  out.x.push_back(static_cast<float>(cell.x));
  out.y.push_back(static_cast<float>(cell.y));
  out.vx.push_back(cell.vx);
  out.vy.push_back(cell.vy);
  out.p_static.push_back(cell.p_static);
  out.p_dynamic.push_back(cell.p_dynamic);
  out.state.push_back(static_cast<std::uint8_t>(cell.state));
  if (grid.scans_since_hit)
  {
    out.scans_since_hit.push_back(grid.scans_since_hit[i]);
  }
  if (grid.v_var_x && grid.v_var_y)
  {
    out.v_var_x.push_back(grid.v_var_x[i]);
    out.v_var_y.push_back(grid.v_var_y[i]);
  }
}

/// Projects the column of `cell` (its ground point, and the points above it in column mode) into
/// the image; the points behind the camera or outside the image are counted, not kept.
void projectColumn(const GridCellsView& grid, const SelectedCell& cell, const ColumnGeometry& column,
                   const GridProjectionConfig& config, ProjectedCells& out)
{
  // The column is linear in z: the ground point plus k steps along the z column of m.
  const Eigen::Matrix<double, 3, 4>& m = column.m;
  const double x = cell.x;
  const double y = cell.y;
  const double z = cell.z;
  const double hu0 = m(0, 0) * x + m(0, 1) * y + m(0, 2) * z + m(0, 3);
  const double hv0 = m(1, 0) * x + m(1, 1) * y + m(1, 2) * z + m(1, 3);
  const double hw0 = m(2, 0) * x + m(2, 1) * y + m(2, 2) * z + m(2, 3);
  for (int k = 0; k < column.points_per_cell; ++k)
  {
    const double dz = k * column.column_step;
    const double hu = hu0 + m(0, 2) * dz;
    const double hv = hv0 + m(1, 2) * dz;
    const double hw = hw0 + m(2, 2) * dz;
    if (!(hw >= config.min_depth))
    {
      ++out.points_behind;
      continue;
    }
    double pu = hu / hw;
    double pv = hv / hw;
    double depth = hw;
    if (k == 0 && config.near_cells_at_bottom && pv >= column.height)
    {
      // The column's point on the bottom row v_b: (hv0 + a dz) / (hw0 + c dz) = v_b.
      const double v_bottom = column.height - 0.5;
      const double a = m(1, 2);
      const double c = m(2, 2);
      const double denominator = a - v_bottom * c;
      const double lift = denominator != 0.0 ? (v_bottom * hw0 - hv0) / denominator : -1.0;
      if (lift >= 0.0 && lift <= config.column_height && hw0 + c * lift >= config.min_depth)
      {
        depth = hw0 + c * lift;
        pu = (hu0 + m(0, 2) * lift) / depth;
        pv = v_bottom;
      }
    }
    if (!(pu >= 0.0 && pv >= 0.0 && pu < column.width && pv < column.height))
    {
      ++out.points_outside;
      continue;
    }
    appendPoint(grid, cell, pu, pv, depth, out);
  }
}
}  // namespace

ProjectedCells projectGrid(const GridCellsView& grid, const PinholeCamera& camera,
                           const ProjectionGeometry& geometry, const GridProjectionConfig& config)
{
  validateProjection(grid, geometry, config);
  // Grid frame point → homogeneous pixel in one 3×4 matrix.
  const Eigen::Matrix<double, 3, 4> m = camera.projection() * geometry.camera_from_grid.matrix();
  ColumnGeometry column;
  column.m = m;
  column.ground_z = geometry.ground_z;
  column.points_per_cell = config.column_mode ? config.column_points : 1;
  column.column_step = config.column_mode ? config.column_height / (config.column_points - 1) : 0.0;
  column.width = camera.width();
  column.height = camera.height();
  const double dt = config.predict_to_image_stamp ? geometry.time_offset : 0.0;
  const double threshold = config.occupied_threshold;

  ProjectedCells out;
  out.resolution = grid.resolution;
  // Reserve for every candidate cell first: one cheap pass instead of repeated reallocations.
  out.reserve(candidateCells(grid, threshold) * static_cast<std::size_t>(column.points_per_cell));
  for (std::uint32_t row = 0; row < grid.height; ++row)
  {
    const double cell_y = grid.origin_y + (row + 0.5) * grid.resolution;
    const std::size_t row_start = static_cast<std::size_t>(row) * grid.width;
    for (std::uint32_t col = 0; col < grid.width; ++col)
    {
      SelectedCell cell;
      cell.index = row_start + col;
      cell.p_static = grid.p_static[cell.index];
      cell.p_dynamic = grid.p_dynamic[cell.index];
      if (!std::isfinite(cell.p_static) || !std::isfinite(cell.p_dynamic))
      {
        ++out.cells_invalid;
        continue;
      }
      if (cell.p_static < threshold && cell.p_dynamic < threshold)
      {
        continue;
      }
      ++out.cells_selected;
      if (!moveToImageStamp(grid, config, dt, grid.origin_x + (col + 0.5) * grid.resolution, cell_y, cell))
      {
        ++out.cells_invalid;
        continue;
      }
      const float cell_ground = config.ground_from_grid && grid.ground_z
                                    ? grid.ground_z[cell.index]
                                    : std::numeric_limits<float>::quiet_NaN();
      cell.z = std::isfinite(cell_ground) ? static_cast<double>(cell_ground) : column.ground_z;
      projectColumn(grid, cell, column, config, out);
    }
  }
  return out;
}

}  // namespace grid_vision_fusion
