// Inverse sensor model; equations in doc/grid_filter.md ("Inverse sensor model").
#include "grid_vision_fusion/grid/inverse_sensor_model.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <stdexcept>
#include <string>

namespace grid_vision_fusion
{
namespace
{
constexpr auto kPi = static_cast<float>(M_PI);
constexpr float kInf = std::numeric_limits<float>::infinity();
/// How far before a sector's nearest obstacle its ground is read for the cells at and behind that
/// obstacle [m] (groundHeightAt()): before the range bins the obstacle's own low points fall in.
constexpr float kGroundBeforeObstacle = 0.5F;
// Blocks of a fixed size (points, sectors, grid rows, grid columns): per-block counters summed in
// block order and per-sector minima / maxima make the result independent of the thread count.
constexpr std::size_t kPointBlock = 8192;
constexpr std::size_t kSectorBlock = 16;
constexpr int kRowBlock = 8;
constexpr int kColumnBlock = 64;

void require(bool condition, const char* field, const std::string& what)
{
  if (!condition)
  {
    throw std::invalid_argument(std::string("InverseSensorModelConfig.") + field + " " + what);
  }
}

inline float atan2Approx(float y, float x)
{
  // atan on [0, 1] by a degree-11 odd minimax polynomial (|error| < 1e-5 rad), then octant
  // reconstruction.
  const float ax = std::fabs(x);
  const float ay = std::fabs(y);
  const float mx = std::max(ax, ay);
  if (mx == 0.0F)
  {
    return 0.0F;
  }
  const float a = std::min(ax, ay) / mx;
  const float s = a * a;
  float r =
      a * (0.99997726F + s * (-0.33262347F +
                              s * (0.19354346F + s * (-0.11643287F + s * (0.05265332F + s * -0.01172120F)))));
  if (ay > ax)
  {
    r = 0.5F * kPi - r;
  }
  if (x < 0.0F)
  {
    r = kPi - r;
  }
  return y < 0.0F ? -r : r;
}

float readFloat(const std::uint8_t* p)
{
  float v;
  std::memcpy(&v, p, sizeof(float));
  return v;
}

/// f(block, first_point, end_point) for the blocks of kPointBlock of `points` points.
template <typename F>
void forPointBlocks(const ParallelBlocks& parallel, std::size_t points, const F& f)
{
  parallel.run(blockCount(points, kPointBlock),
               [&](std::size_t b) { f(b, b * kPointBlock, std::min(points, (b + 1) * kPointBlock)); });
}

/// f(block, first_row, end_row) for the blocks of kRowBlock rows of `grid`.
template <typename F>
void forRowBlocks(const ParallelBlocks& parallel, const GridGeometry& grid, const F& f)
{
  parallel.run(blockCount(static_cast<std::size_t>(grid.height), kRowBlock),
               [&](std::size_t b)
               {
                 const int r0 = static_cast<int>(b) * kRowBlock;
                 f(b, r0, std::min(grid.height, r0 + kRowBlock));
               });
}

/// f(sector) for every one of `sectors` sectors, in blocks of kSectorBlock sectors.
template <typename F>
void forSectors(const ParallelBlocks& parallel, std::size_t sectors, const F& f)
{
  parallel.run(blockCount(sectors, kSectorBlock),
               [&](std::size_t sb)
               {
                 for (std::size_t s = sb * kSectorBlock; s < std::min(sectors, (sb + 1) * kSectorBlock); ++s)
                 {
                   f(s);
                 }
               });
}
}  // namespace

PointCloudView PointCloudView::packedXyz(const float* xyz, std::size_t count)
{
  PointCloudView view;
  view.data = reinterpret_cast<const std::uint8_t*>(xyz);
  view.width = count;
  view.height = 1;
  view.point_step = 3 * sizeof(float);
  view.row_step = count * view.point_step;
  return view;
}

void InverseSensorModelConfig::validate() const
{
  require(std::isfinite(sensor_height) && sensor_height > 0.0, "sensor_height", "must be > 0 [m]");
  require(std::isfinite(min_range) && min_range >= 0.0, "min_range", "must be >= 0 [m]");
  require(std::isfinite(max_range) && max_range > min_range && max_range <= 500.0, "max_range",
          "must be in (min_range, 500] [m]");
  require(angular_resolution >= 0.05 && angular_resolution <= 10.0, "angular_resolution",
          "must be in [0.05, 10] [deg]");
  require(std::isfinite(range_resolution) && range_resolution > 0.0 && max_range / range_resolution <= 1e5,
          "range_resolution", "must be > 0 and at least max_range / 1e5 [m]");
  require(std::isfinite(max_ground_slope) && max_ground_slope >= 0.0, "max_ground_slope", "must be >= 0");
  require(std::isfinite(ground_tolerance) && ground_tolerance >= 0.0, "ground_tolerance", "must be >= 0 [m]");
  require(std::isfinite(min_obstacle_height) && min_obstacle_height > 0.0, "min_obstacle_height",
          "must be > 0 [m]");
  require(std::isfinite(max_obstacle_height) && max_obstacle_height > min_obstacle_height,
          "max_obstacle_height", "must be > min_obstacle_height [m]");
  require(p_occupied > 0.5 && p_occupied < 1.0, "p_occupied", "must be in (0.5, 1)");
  require(p_free > 0.0 && p_free < 0.5, "p_free", "must be in (0, 0.5)");
  require(std::isfinite(range_sigma) && range_sigma > 0.0, "range_sigma", "must be > 0 [m]");
}

float fastAtan2(float y, float x)
{
  return atan2Approx(y, x);
}

InverseSensorModel::InverseSensorModel(const InverseSensorModelConfig& config) : config_(config)
{
  config_.validate();
  sectors_ = static_cast<int>(std::ceil(360.0 / config_.angular_resolution));
  sectors_per_rad_ = static_cast<float>(sectors_ / (2.0 * M_PI));
  range_bins_ = static_cast<int>(std::ceil(config_.max_range / config_.range_resolution)) + 1;
  bin_min_z_.resize(static_cast<std::size_t>(sectors_) * static_cast<std::size_t>(range_bins_));
  ground_z_.resize(bin_min_z_.size());
  first_hit_.resize(static_cast<std::size_t>(sectors_));
  farthest_return_.resize(static_cast<std::size_t>(sectors_));
}

inline int InverseSensorModel::sectorOf(float dx, float dy) const
{
  int s = static_cast<int>((atan2Approx(dy, dx) + kPi) * sectors_per_rad_);
  return s >= sectors_ ? s - sectors_ : (s < 0 ? 0 : s);
}

float InverseSensorModel::groundHeight(double azimuth, double range) const
{
  const int s = sectorOf(static_cast<float>(std::cos(azimuth)), static_cast<float>(std::sin(azimuth)));
  const int b = std::clamp(static_cast<int>(range / config_.range_resolution), 0, range_bins_ - 1);
  return ground_z_[static_cast<std::size_t>(s) * static_cast<std::size_t>(range_bins_) +
                   static_cast<std::size_t>(b)];
}

float InverseSensorModel::groundHeightAt(float dx, float dy) const
{
  const float range = std::hypot(dx, dy);
  if (!(range <= static_cast<float>(config_.max_range)))
  {
    return std::numeric_limits<float>::quiet_NaN();
  }
  // From the sector's nearest obstacle on (and behind it, where the scan does not reach the
  // ground), the ground just before that obstacle: the lowest points of an obstacle's own range
  // bins can pass for ground within ground_tolerance, bin after bin, and climb it.
  const int s = sectorOf(dx, dy);
  const float before = first_hit_[static_cast<std::size_t>(s)] - kGroundBeforeObstacle;
  const float r = range < before ? range : std::max(0.0F, before);
  const int b = std::min(static_cast<int>(r / static_cast<float>(config_.range_resolution)), range_bins_ - 1);
  return ground_z_[static_cast<std::size_t>(s) * static_cast<std::size_t>(range_bins_) +
                   static_cast<std::size_t>(b)];
}

InverseSensorModelStats InverseSensorModel::compute(const PointCloudView& cloud,
                                                    const Eigen::Isometry3d& world_from_sensor,
                                                    const GridGeometry& grid, std::vector<float>& occupancy)
{
  static const ParallelBlocks serial(1);
  return compute(cloud, world_from_sensor, grid, occupancy, serial);
}

InverseSensorModelStats InverseSensorModel::compute(const PointCloudView& cloud,
                                                    const Eigen::Isometry3d& world_from_sensor,
                                                    const GridGeometry& grid, std::vector<float>& occupancy,
                                                    const ParallelBlocks& parallel)
{
  InverseSensorModelStats stats;
  stats.points = cloud.size();
  const std::size_t point_blocks = blockCount(cloud.size(), kPointBlock);
  const std::size_t row_blocks = blockCount(static_cast<std::size_t>(grid.height), kRowBlock);
  const Eigen::Vector3d origin = world_from_sensor.translation();
  const double ox = origin.x() - grid.originX();
  const double oy = origin.y() - grid.originY();
  prepareBuffers(cloud.size(), std::max(point_blocks, row_blocks), parallel);

  // Points into the world-aligned sensor-centred polar frame; the ground along each sector from
  // the lowest point of each range bin.
  binPoints(cloud, world_from_sensor.linear().cast<float>(), parallel);
  addBlockStats(point_blocks, stats);
  lowestPointPerBin(cloud.size());
  estimateGround(parallel);

  // Points classified against the ground; per sector the nearest obstacle hit and the farthest
  // return; the cells holding obstacle points (and, hit_neighbours_not_free, their neighbours).
  classifyPoints(grid, ox, oy, parallel);
  addBlockStats(point_blocks, stats);
  combineSectorRanges(point_blocks, parallel);
  markHitCells(grid, parallel);
  if (config_.hit_neighbours_not_free)
  {
    dilateHits(grid, parallel);
  }

  // Polar ray casting: p_o of every cell.
  castRays(grid, ox, oy, occupancy, parallel);
  addBlockStats(row_blocks, stats);
  return stats;
}

void InverseSensorModel::prepareBuffers(std::size_t points, std::size_t stat_blocks,
                                        const ParallelBlocks& parallel)
{
  const auto sectors = static_cast<std::size_t>(sectors_);
  const std::size_t point_blocks = blockCount(points, kPointBlock);
  parallelFill(parallel, bin_min_z_, kInf);
  point_bin_.resize(points);
  point_x_.resize(points);
  point_y_.resize(points);
  point_dz_.resize(points);
  point_cell_.resize(points);
  block_stats_.assign(stat_blocks, InverseSensorModelStats());
  block_first_hit_.resize(point_blocks * sectors);
  block_farthest_.resize(point_blocks * sectors);
}

void InverseSensorModel::addBlockStats(std::size_t blocks, InverseSensorModelStats& stats)
{
  for (std::size_t b = 0; b < blocks; ++b)
  {
    const InverseSensorModelStats& s = block_stats_[b];
    stats.invalid_points += s.invalid_points;
    stats.out_of_range += s.out_of_range;
    stats.ground_points += s.ground_points;
    stats.obstacle_points += s.obstacle_points;
    stats.overhang_points += s.overhang_points;
    stats.occupied_cells += s.occupied_cells;
    block_stats_[b] = InverseSensorModelStats();
  }
}

void InverseSensorModel::binPoints(const PointCloudView& cloud, const Eigen::Matrix3f& rot,
                                   const ParallelBlocks& parallel)
{
  const float min_r2 = static_cast<float>(config_.min_range * config_.min_range);
  const float max_r2 = static_cast<float>(config_.max_range * config_.max_range);
  const float inv_range_res = static_cast<float>(1.0 / config_.range_resolution);
  const auto bins = static_cast<std::size_t>(range_bins_);
  forPointBlocks(
      parallel, cloud.size(),
      [&](std::size_t b, std::size_t begin, std::size_t end)
      {
        InverseSensorModelStats& bs = block_stats_[b];
        std::size_t row = begin / cloud.width;
        std::size_t col = begin % cloud.width;
        for (std::size_t i = begin; i < end; ++i, ++col)
        {
          if (col == cloud.width)
          {
            col = 0;
            ++row;
          }
          const std::uint8_t* p = cloud.data + row * cloud.row_step + col * cloud.point_step;
          const Eigen::Vector3f ps(readFloat(p + cloud.x_offset), readFloat(p + cloud.y_offset),
                                   readFloat(p + cloud.z_offset));
          point_bin_[i] = -1;
          if (!ps.allFinite())
          {
            ++bs.invalid_points;
            continue;
          }
          const Eigen::Vector3f d = rot * ps;
          const float r2 = d.x() * d.x() + d.y() * d.y();
          if (r2 < min_r2 || r2 > max_r2)
          {
            ++bs.out_of_range;
            continue;
          }
          const int rb = std::min(static_cast<int>(std::sqrt(r2) * inv_range_res), range_bins_ - 1);
          point_bin_[i] = static_cast<std::int32_t>(static_cast<std::size_t>(sectorOf(d.x(), d.y())) * bins +
                                                    static_cast<std::size_t>(rb));
          point_x_[i] = d.x();
          point_y_[i] = d.y();
          point_dz_[i] = d.z();
        }
      });
}

void InverseSensorModel::lowestPointPerBin(std::size_t points)
{
  for (std::size_t i = 0; i < points; ++i)  // a minimum: the same in any order
  {
    const std::int32_t bin = point_bin_[i];
    if (bin >= 0)
    {
      float& z = bin_min_z_[static_cast<std::size_t>(bin)];
      z = std::min(z, point_dz_[i]);
    }
  }
}

void InverseSensorModel::estimateGround(const ParallelBlocks& parallel)
{
  // A bin's lowest point is ground when it lies within ground_tolerance + max_ground_slope *
  // (distance to the last ground bin) of that bin's height; bins without accepted ground keep the
  // last ground height.
  const float tol = static_cast<float>(config_.ground_tolerance);
  const float slope = static_cast<float>(config_.max_ground_slope);
  const float res = static_cast<float>(config_.range_resolution);
  const auto bins = static_cast<std::size_t>(range_bins_);
  forSectors(parallel, static_cast<std::size_t>(sectors_),
             [&](std::size_t s)
             {
               float g = static_cast<float>(-config_.sensor_height);
               float r_prev = 0.0F;
               const std::size_t base = s * bins;
               for (int b = 0; b < range_bins_; ++b)
               {
                 const float z = bin_min_z_[base + static_cast<std::size_t>(b)];
                 const float r = (static_cast<float>(b) + 0.5F) * res;
                 if (z < kInf && std::fabs(z - g) <= tol + slope * (r - r_prev))
                 {
                   g = z;
                   r_prev = r;
                 }
                 ground_z_[base + static_cast<std::size_t>(b)] = g;
               }
             });
}

void InverseSensorModel::classifyPoints(const GridGeometry& grid, double ox, double oy,
                                        const ParallelBlocks& parallel)
{
  const float h_min = static_cast<float>(config_.min_obstacle_height);
  const float h_max = static_cast<float>(config_.max_obstacle_height);
  const double inv_cell = 1.0 / grid.resolution;
  const auto bins = static_cast<std::size_t>(range_bins_);
  const auto sectors = static_cast<std::size_t>(sectors_);
  forPointBlocks(parallel, point_bin_.size(),
                 [&](std::size_t blk, std::size_t begin, std::size_t end)
                 {
                   InverseSensorModelStats& bs = block_stats_[blk];
                   float* first_hit = block_first_hit_.data() + blk * sectors;
                   float* farthest = block_farthest_.data() + blk * sectors;
                   std::fill(first_hit, first_hit + sectors, kInf);
                   std::fill(farthest, farthest + sectors, 0.0F);
                   for (std::size_t k = begin; k < end; ++k)
                   {
                     point_cell_[k] = -1;
                     const std::int32_t bin = point_bin_[k];
                     if (bin < 0)
                     {
                       continue;
                     }
                     const auto sector = static_cast<std::size_t>(bin) / bins;
                     const float h = point_dz_[k] - ground_z_[static_cast<std::size_t>(bin)];
                     const float r = std::sqrt(point_x_[k] * point_x_[k] + point_y_[k] * point_y_[k]);
                     if (h > h_max)
                     {
                       ++bs.overhang_points;
                       continue;
                     }
                     farthest[sector] = std::max(farthest[sector], r);
                     if (h < h_min)
                     {
                       ++bs.ground_points;
                       continue;
                     }
                     ++bs.obstacle_points;
                     first_hit[sector] = std::min(first_hit[sector], r);
                     const double fc = std::floor((ox + point_x_[k]) * inv_cell);
                     const double fr = std::floor((oy + point_y_[k]) * inv_cell);
                     if (fc >= 0.0 && fr >= 0.0 && fc < grid.width && fr < grid.height)
                     {
                       point_cell_[k] =
                           static_cast<std::int32_t>(grid.index(static_cast<int>(fr), static_cast<int>(fc)));
                     }
                   }
                 });
}

void InverseSensorModel::combineSectorRanges(std::size_t point_blocks, const ParallelBlocks& parallel)
{
  const auto sectors = static_cast<std::size_t>(sectors_);
  forSectors(parallel, sectors,
             [&](std::size_t s)
             {
               float hit = kInf;
               float far = 0.0F;
               for (std::size_t b = 0; b < point_blocks; ++b)
               {
                 hit = std::min(hit, block_first_hit_[b * sectors + s]);
                 far = std::max(far, block_farthest_[b * sectors + s]);
               }
               first_hit_[s] = hit;
               farthest_return_[s] = far;
             });
}

void InverseSensorModel::markHitCells(const GridGeometry& grid, const ParallelBlocks& parallel)
{
  cell_hit_.resize(grid.cellCount());
  parallelFill(parallel, cell_hit_, std::uint8_t{0});
  for (std::size_t k = 0; k < point_cell_.size(); ++k)
  {
    if (point_cell_[k] >= 0)
    {
      cell_hit_[static_cast<std::size_t>(point_cell_[k])] = 1;
    }
  }
}

void InverseSensorModel::dilateHits(const GridGeometry& grid, const ParallelBlocks& parallel)
{
  // A 3x3 dilation of the hits, as a horizontal then a vertical pass.
  const int w = grid.width;
  const int h = grid.height;
  near_hit_.resize(grid.cellCount());
  forRowBlocks(parallel, grid,
               [&](std::size_t, int r_begin, int r_end)
               {
                 for (int row = r_begin; row < r_end; ++row)
                 {
                   const std::uint8_t* in = cell_hit_.data() + grid.index(row, 0);
                   std::uint8_t* out = near_hit_.data() + grid.index(row, 0);
                   for (int col = 0; col < w; ++col)
                   {
                     out[col] = static_cast<std::uint8_t>(in[col] | (col > 0 ? in[col - 1] : 0) |
                                                          (col + 1 < w ? in[col + 1] : 0));
                   }
                 }
               });
  parallel.run(blockCount(static_cast<std::size_t>(w), kColumnBlock),
               [&](std::size_t b)
               {
                 const int c0 = static_cast<int>(b) * kColumnBlock;
                 const int c1 = std::min(w, c0 + kColumnBlock);
                 for (int col = c0; col < c1; ++col)
                 {
                   std::uint8_t above = 0;
                   for (int row = 0; row < h; ++row)
                   {
                     const std::size_t idx = grid.index(row, col);
                     const std::uint8_t here = near_hit_[idx];
                     const std::uint8_t below =
                         row + 1 < h ? near_hit_[idx + static_cast<std::size_t>(w)] : 0;
                     near_hit_[idx] = static_cast<std::uint8_t>(here | above | below);
                     above = here;
                   }
                 }
               });
}

void InverseSensorModel::castRays(const GridGeometry& grid, double ox, double oy,
                                  std::vector<float>& occupancy, const ParallelBlocks& parallel)
{
  // The "lookup" of a cell is its sector and range from the sensor, computed with the same
  // fastAtan2 as the points:
  //   hit range h, sigma s, g(d) = exp(-d^2 / (2 s^2)) (0 beyond 3 s):
  //   r <  h : p = p_free + (p_occ - p_free) g(r - h)
  //   r >= h : p = 0.5 + (p_occ - 0.5) g(r - h)
  //   no hit : p = p_free up to the farthest return, 0.5 beyond
  //   cells holding obstacle points: p = p_occ.
  occupancy.resize(grid.cellCount());
  const bool protect = config_.hit_neighbours_not_free;
  const float p_occ = static_cast<float>(config_.p_occupied);
  const float p_fr = static_cast<float>(config_.p_free);
  const float sigma = static_cast<float>(config_.range_sigma);
  const float inv_two_s2 = 1.0F / (2.0F * sigma * sigma);
  const float band = 3.0F * sigma;
  const float cell = static_cast<float>(grid.resolution);
  const float min_r = static_cast<float>(config_.min_range);
  const float max_r = static_cast<float>(config_.max_range);
  forRowBlocks(parallel, grid,
               [&](std::size_t blk, int r_begin, int r_end)
               {
                 InverseSensorModelStats& bs = block_stats_[blk];
                 for (int row = r_begin; row < r_end; ++row)
                 {
                   const float dy = static_cast<float>((row + 0.5) * grid.resolution - oy);
                   const std::size_t base = grid.index(row, 0);
                   for (int col = 0; col < grid.width; ++col)
                   {
                     const std::size_t idx = base + static_cast<std::size_t>(col);
                     float p = 0.5F;
                     if (cell_hit_[idx])
                     {
                       occupancy[idx] = p_occ;
                       ++bs.occupied_cells;
                       continue;
                     }
                     const float dx = (static_cast<float>(col) + 0.5F) * cell - static_cast<float>(ox);
                     const float r = std::sqrt(dx * dx + dy * dy);
                     if (r >= min_r && r <= max_r)
                     {
                       const auto sector = static_cast<std::size_t>(sectorOf(dx, dy));
                       const float hit = first_hit_[sector];
                       if (hit < kInf)
                       {
                         const float d = r - hit;
                         const float g = std::fabs(d) < band ? std::exp(-d * d * inv_two_s2) : 0.0F;
                         p = d < 0.0F ? p_fr + (p_occ - p_fr) * g : 0.5F + (p_occ - 0.5F) * g;
                       }
                       else if (r <= farthest_return_[sector])
                       {
                         p = p_fr;
                       }
                       if (protect && near_hit_[idx] && p < 0.5F)
                       {
                         p = 0.5F;
                       }
                     }
                     occupancy[idx] = p;
                   }
                 }
               });
}

}  // namespace grid_vision_fusion
