// Inverse sensor model of a 3-D lidar scan on the dynamic grid: ground removal per polar sector
// and polar ray casting (free before the first obstacle hit, occupied around it, unknown
// behind it). See doc/grid_filter.md, section "Inverse sensor model".
#pragma once

#include <Eigen/Geometry>

#include <cstddef>
#include <cstdint>
#include <vector>

#include "grid_vision_fusion/grid/grid_map.h"
#include "grid_vision_fusion/grid/parallel_blocks.h"

namespace grid_vision_fusion
{
/// A read-only view of float32 x, y, z values inside a foreign buffer (e.g. the data of a
/// sensor_msgs/PointCloud2), so the scan is never copied. Point (row, col) starts at
/// data + row * row_step + col * point_step; its coordinates are the float32 at x_offset,
/// y_offset and z_offset bytes from there, in the sensor frame [m].
struct PointCloudView
{
  const std::uint8_t* data = nullptr;
  std::size_t width = 0;       ///< points per row
  std::size_t height = 0;      ///< rows (1 for an unorganised cloud)
  std::size_t point_step = 0;  ///< bytes between consecutive points of a row
  std::size_t row_step = 0;    ///< bytes between rows
  std::size_t x_offset = 0;
  std::size_t y_offset = 4;
  std::size_t z_offset = 8;

  std::size_t size() const { return width * height; }
  /// View of a packed array of xyz float triples (point_step 12), e.g. std::vector<Eigen::Vector3f>.
  static PointCloudView packedXyz(const float* xyz, std::size_t count);
};

/// Parameters of the inverse sensor model. Defaults: Velodyne HDL-64E on KITTI.
struct InverseSensorModelConfig
{
  double sensor_height = 1.73;       ///< lidar above the ground, first ground guess [m] (>0)
  double min_range = 2.5;            ///< horizontal range below which points are ignored (ego body) [m] (>=0)
  double max_range = 70.0;           ///< horizontal range beyond which points are ignored [m] (> min_range)
  double angular_resolution = 0.5;   ///< width of a polar sector [deg] (0.05..10)
  double range_resolution = 0.2;     ///< length of a range bin of the ground estimate [m] (>0)
  double max_ground_slope = 0.15;    ///< largest ground gradient along a sector [m/m] (>=0)
  double ground_tolerance = 0.15;    ///< ground step allowed between consecutive ground bins [m] (>=0)
  double min_obstacle_height = 0.3;  ///< obstacle points start this far above the ground [m] (>0)
  double max_obstacle_height = 2.5;  ///< points higher above the ground are overhangs, ignored [m]
  double p_occupied = 0.95;          ///< P(occupied) at an obstacle hit (0.5, 1)
  double p_free = 0.05;              ///< P(occupied) of a cell seen free (0, 0.5)
  double range_sigma = 0.2;          ///< std-dev of the hit range, width of the occupied band [m] (>0)
  /// A cell next to (8-neighbourhood) a cell holding obstacle points is never observed free: at
  /// grazing angles the nearest hit of a polar sector can lie beyond a surface that crosses the
  /// sector, and the cells of that surface would flicker between hit and free from scan to scan
  /// (false motion evidence). Such a cell gets p_o = 1/2 instead of p_o < 1/2.
  bool hit_neighbours_not_free = true;

  /// @throws std::invalid_argument naming the first field out of its range.
  void validate() const;
};

/// Counters of one scan.
struct InverseSensorModelStats
{
  std::size_t points = 0;          ///< points in the view
  std::size_t invalid_points = 0;  ///< NaN/Inf coordinates, dropped
  std::size_t out_of_range = 0;    ///< outside [min_range, max_range] horizontally
  std::size_t ground_points = 0;
  std::size_t obstacle_points = 0;
  std::size_t overhang_points = 0;  ///< above max_obstacle_height over the ground
  std::size_t occupied_cells = 0;   ///< cells holding obstacle points
};

/// Computes, for every cell of a grid, the probability p_o that the cell is occupied given one
/// scan. Keeps its buffers between scans (no allocation in steady state). Not thread-safe (one
/// caller at a time); compute() may run its passes on several threads, with the same result.
class InverseSensorModel
{
public:
  /// @throws std::invalid_argument when `config` is invalid.
  explicit InverseSensorModel(const InverseSensorModelConfig& config);

  const InverseSensorModelConfig& config() const { return config_; }

  /// Evaluates the scan `cloud` (sensor frame) taken at pose `world_from_sensor` (fixed frame
  /// <- sensor) on `grid`. Writes one p_o in [0, 1] per cell to `occupancy` (resized; 0.5 =
  /// no information) and returns the counters.
  InverseSensorModelStats compute(const PointCloudView& cloud, const Eigen::Isometry3d& world_from_sensor,
                                  const GridGeometry& grid, std::vector<float>& occupancy);
  /// The same on the threads of `parallel` (blocks of points, sectors and grid rows); the result
  /// does not depend on the thread count.
  InverseSensorModelStats compute(const PointCloudView& cloud, const Eigen::Isometry3d& world_from_sensor,
                                  const GridGeometry& grid, std::vector<float>& occupancy,
                                  const ParallelBlocks& parallel);

  /// Ground height estimate of the last scan at horizontal range `range` [m] in the sector of
  /// the fixed-frame azimuth `azimuth` [rad], relative to the sensor origin [m].
  float groundHeight(double azimuth, double range) const;
  /// The ground under the point at the horizontal offset (`dx`, `dy`) [m] from the sensor,
  /// fixed-frame axes, relative to the sensor origin [m]: groundHeight() at its range, or, at and
  /// beyond the sector's nearest obstacle hit, 0.5 m before that hit (an obstacle's own lowest
  /// points can pass for ground within ground_tolerance, bin after bin, and climb it: up to 1.3 m
  /// under the pedestrians of the scenario suite). NaN beyond max_range.
  float groundHeightAt(float dx, float dy) const;

private:
  int sectorOf(float dx, float dy) const;
  /// Sizes the per-point and per-block buffers for `points` points and `stat_blocks` blocks of
  /// counters; every bin's lowest z to +infinity.
  void prepareBuffers(std::size_t points, std::size_t stat_blocks, const ParallelBlocks& parallel);
  /// Adds the counters of the first `blocks` blocks to `stats` in block order and clears them.
  void addBlockStats(std::size_t blocks, InverseSensorModelStats& stats);
  /// Pass 1: each point into the world-aligned sensor-centred polar frame (`rot`: world <- sensor
  /// rotation) and its (sector, range bin); invalid and out-of-range points dropped.
  void binPoints(const PointCloudView& cloud, const Eigen::Matrix3f& rot, const ParallelBlocks& parallel);
  /// The lowest point of each (sector, range bin).
  void lowestPointPerBin(std::size_t points);
  /// Ground height along each sector, bin by bin outwards from the sensor.
  void estimateGround(const ParallelBlocks& parallel);
  /// Pass 2: each point as overhang, ground or obstacle; per point block and sector the nearest
  /// obstacle hit and the farthest return; the cell of each obstacle point. (ox, oy): the sensor
  /// relative to the grid's corner [m].
  void classifyPoints(const GridGeometry& grid, double ox, double oy, const ParallelBlocks& parallel);
  /// The per-block nearest hits and farthest returns combined per sector.
  void combineSectorRanges(std::size_t point_blocks, const ParallelBlocks& parallel);
  /// The cells that hold obstacle points.
  void markHitCells(const GridGeometry& grid, const ParallelBlocks& parallel);
  /// The cells next to a hit, which are never free (hit_neighbours_not_free).
  void dilateHits(const GridGeometry& grid, const ParallelBlocks& parallel);
  /// Polar ray casting per cell centre: p_o of every cell from its sector's nearest hit and
  /// farthest return.
  void castRays(const GridGeometry& grid, double ox, double oy, std::vector<float>& occupancy,
                const ParallelBlocks& parallel);

  InverseSensorModelConfig config_;
  int sectors_ = 0;
  int range_bins_ = 0;
  float sectors_per_rad_ = 0.0F;
  std::vector<float> bin_min_z_;         // per (sector, range bin): lowest z relative to the sensor
  std::vector<float> ground_z_;          // per (sector, range bin): ground estimate
  std::vector<float> first_hit_;         // per sector: range of the nearest obstacle point
  std::vector<float> farthest_return_;   // per sector: range of the farthest valid point
  std::vector<std::int32_t> point_bin_;  // per point: sector * range_bins + bin, -1 when dropped
  std::vector<float> point_dz_;          // per point: z relative to the sensor, world-aligned
  std::vector<float> point_x_;           // per point: x relative to the sensor, world-aligned
  std::vector<float> point_y_;
  std::vector<std::uint8_t> cell_hit_;    // per cell: holds obstacle points
  std::vector<std::uint8_t> near_hit_;    // per cell: a cell of its 3x3 neighbourhood holds obstacle points
  std::vector<std::int32_t> point_cell_;  // per point: cell of an obstacle point, -1 otherwise
  std::vector<InverseSensorModelStats> block_stats_;  // counters per block, summed in block order
  std::vector<float> block_first_hit_;                // per (point block, sector), min-combined
  std::vector<float> block_farthest_;                 // per (point block, sector), max-combined
};

/// atan2 with |error| < 1e-5 rad, branch-light (used for points and cells alike so that they
/// fall in consistent sectors). Result in (-pi, pi].
float fastAtan2(float y, float x);

}  // namespace grid_vision_fusion
