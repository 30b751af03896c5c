// The world-aligned cell lattice of the dynamic occupancy grid and its per-cell state arrays.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "grid_vision_fusion/grid/parallel_blocks.h"

namespace grid_vision_fusion
{
/// Geometry of a square-celled grid whose axes are aligned with the fixed frame. The grid lies
/// on the fixed lattice of cells of size `resolution` anchored at the frame origin: cell (0,0)
/// of the grid is lattice cell (origin_col, origin_row), so its corner is at
/// (origin_col * resolution, origin_row * resolution) [m]. Moving the grid only changes the
/// two integers, which is why following the vehicle never resamples (no drift).
struct GridGeometry
{
  int width = 300;              ///< cells along +x (columns)
  int height = 300;             ///< cells along +y (rows)
  double resolution = 0.2;      ///< cell edge [m]
  std::int64_t origin_col = 0;  ///< lattice column of grid cell (0,0)
  std::int64_t origin_row = 0;  ///< lattice row of grid cell (0,0)

  std::size_t cellCount() const { return static_cast<std::size_t>(width) * static_cast<std::size_t>(height); }
  /// x of the corner of cell (0,0) in the fixed frame [m].
  double originX() const { return static_cast<double>(origin_col) * resolution; }
  /// y of the corner of cell (0,0) in the fixed frame [m].
  double originY() const { return static_cast<double>(origin_row) * resolution; }
  /// Row-major index of (row, col); no bounds check.
  std::size_t index(int row, int col) const
  {
    return static_cast<std::size_t>(row) * static_cast<std::size_t>(width) + static_cast<std::size_t>(col);
  }
  /// Cell holding the fixed-frame point (x, y) [m]; false when it lies outside the grid.
  bool cellOf(double x, double y, int& row, int& col) const;
  /// Fixed-frame centre of cell (row, col) [m].
  double cellCenterX(int col) const { return originX() + (col + 0.5) * resolution; }
  double cellCenterY(int row) const { return originY() + (row + 0.5) * resolution; }
};

/// Per-cell state of the four-state filter, structure of arrays, row-major like GridGeometry.
/// p_static + p_dynamic + p_free + p_unknown = 1 in every cell.
struct CellStates
{
  std::vector<float> p_static;   ///< P(S), static occupied
  std::vector<float> p_dynamic;  ///< P(D), dynamic occupied
  std::vector<float> p_free;     ///< P(E), empty
  std::vector<float> p_unknown;  ///< P(U), unknown
  std::vector<float> vx;         ///< mean velocity along +x given D [m/s]
  std::vector<float> vy;         ///< mean velocity along +y given D [m/s]
  std::vector<float> v_var_x;    ///< velocity variance along x given D [m^2/s^2]
  std::vector<float> v_var_y;    ///< velocity variance along y given D [m^2/s^2]

  /// Resizes to `cells` cells and sets them all to "unknown": P(U) = 1, velocity 0 with
  /// variance `prior_velocity_variance` [m^2/s^2].
  void reset(std::size_t cells, float prior_velocity_variance);
  std::size_t size() const { return p_unknown.size(); }
};

/// Moves the content of every array of `states` so that cell (r, c) of the old grid ends up in
/// cell (r - d_row, c - d_col) of the new one, which is the old grid moved by (d_col, d_row)
/// cells; cells that enter the grid are set to unknown (see CellStates::reset).
void shiftCells(CellStates& states, int width, int height, std::int64_t d_col, std::int64_t d_row,
                float prior_velocity_variance);
/// The same, one array per block on the threads of `parallel` (the same result).
void shiftCells(CellStates& states, int width, int height, std::int64_t d_col, std::int64_t d_row,
                float prior_velocity_variance, const ParallelBlocks& parallel);

}  // namespace grid_vision_fusion
