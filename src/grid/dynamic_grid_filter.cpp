// CMCDOT-style dynamic occupancy grid filter (a documented reconstruction,
// doc/grid_filter.md, whose equation numbers the comments below refer to): its
// configuration, construction, update() (the order of the steps) and the move of the grid with
// the sensor. The steps: src/grid/dynamic_grid_cells.cpp, src/grid/dynamic_grid_motion.cpp,
// src/grid/dynamic_grid_particles.cpp; what they share: src/grid/dynamic_grid_steps.h.
#include "grid_vision_fusion/grid/dynamic_grid_filter.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include "dynamic_grid_steps.h"

namespace grid_vision_fusion
{
using dynamic_grid_detail::kBucket;
using dynamic_grid_detail::kParticleBlock;
using dynamic_grid_detail::kRowBlock;
using dynamic_grid_detail::normalTable;
using dynamic_grid_detail::Row;
using dynamic_grid_detail::scaledRow;

namespace
{
constexpr std::uint16_t kAgesNever = 0xFFFF;  // both ages saturated: never (or not for 255 scans)

void require(bool condition, const char* field, const std::string& what)
{
  if (!condition)
  {
    throw std::invalid_argument(std::string("DynamicGridConfig.") + field + " " + what);
  }
}

void requireProbability(double value, const char* field)
{
  require(std::isfinite(value) && value >= 0.0 && value < 1.0, field, "must be in [0, 1)");
}
}  // namespace

void DynamicGridConfig::validate() const
{
  require(width >= 8 && width <= 4000, "width", "must be in [8, 4000] cells");
  require(height >= 8 && height <= 4000, "height", "must be in [8, 4000] cells");
  require(std::isfinite(resolution) && resolution >= 0.01 && resolution <= 5.0, "resolution",
          "must be in [0.01, 5] m");
  require(std::isfinite(lookahead) && std::fabs(lookahead) <= 1e4, "lookahead", "must be finite [m]");
  require(std::isfinite(max_time_gap) && max_time_gap > 0.0, "max_time_gap", "must be > 0 [s]");
  require(std::isfinite(transition_period) && transition_period > 0.0, "transition_period",
          "must be > 0 [s]");
  requireProbability(eps_static_to_dynamic, "eps_static_to_dynamic");
  requireProbability(eps_static_to_unknown, "eps_static_to_unknown");
  requireProbability(eps_dynamic_to_static, "eps_dynamic_to_static");
  requireProbability(eps_dynamic_to_unknown, "eps_dynamic_to_unknown");
  requireProbability(eps_free_to_static, "eps_free_to_static");
  requireProbability(eps_free_to_dynamic, "eps_free_to_dynamic");
  requireProbability(eps_free_to_unknown, "eps_free_to_unknown");
  requireProbability(eps_unknown_to_static, "eps_unknown_to_static");
  requireProbability(eps_unknown_to_dynamic, "eps_unknown_to_dynamic");
  requireProbability(eps_unknown_to_free, "eps_unknown_to_free");
  require(eps_static_to_dynamic + eps_static_to_unknown < 1.0, "eps_static_to_*", "must sum to < 1");
  require(eps_dynamic_to_static + eps_dynamic_to_unknown < 1.0, "eps_dynamic_to_*", "must sum to < 1");
  require(eps_free_to_static + eps_free_to_dynamic + eps_free_to_unknown < 1.0, "eps_free_to_*",
          "must sum to < 1");
  require(eps_unknown_to_static + eps_unknown_to_dynamic + eps_unknown_to_free < 1.0, "eps_unknown_to_*",
          "must sum to < 1");
  require(particle_count >= 16 && particle_count <= (1 << 24), "particle_count", "must be in [16, 2^24]");
  require(std::isfinite(birth_fraction) && birth_fraction > 0.0 && birth_fraction <= 1.0, "birth_fraction",
          "must be in (0, 1]");
  require(std::isfinite(birth_velocity_sigma) && birth_velocity_sigma > 0.0, "birth_velocity_sigma",
          "must be > 0 [m/s]");
  require(std::isfinite(acceleration_sigma) && acceleration_sigma >= 0.0, "acceleration_sigma",
          "must be >= 0 [m/s^2]");
  require(std::isfinite(max_speed) && max_speed > 0.0, "max_speed", "must be > 0 [m/s]");
  require(std::isfinite(birth_motion_speed) && birth_motion_speed >= 0.0, "birth_motion_speed",
          "must be >= 0 [m/s]");
  require(
      std::isfinite(birth_motion_fraction) && birth_motion_fraction >= 0.0 && birth_motion_fraction <= 1.0,
      "birth_motion_fraction", "must be in [0, 1]");
  require(std::isfinite(motion_window) && motion_window >= 0.0 && motion_window <= 25.0, "motion_window",
          "must be in [0, 25] [s]");
  require(std::isfinite(motion_radius) && motion_radius >= 0.0 && motion_radius <= 20.0, "motion_radius",
          "must be in [0, 20] [m]");
  require(std::isfinite(motion_memory) && motion_memory > 0.0, "motion_memory", "must be > 0 [s]");
  require(std::isfinite(unknown_to_dynamic_by_motion) && unknown_to_dynamic_by_motion >= 0.0 &&
              unknown_to_dynamic_by_motion <= 1.0,
          "unknown_to_dynamic_by_motion", "must be in [0, 1]");
  requireProbability(static_to_dynamic_by_motion, "static_to_dynamic_by_motion");
  requireProbability(propagation_rate, "propagation_rate");
  require(std::isfinite(propagation_length) && propagation_length > 0.0 && propagation_length <= 100.0,
          "propagation_length", "must be in (0, 100] [m]");
  require(dynamic_threshold > 0.0 && dynamic_threshold <= 1.0, "dynamic_threshold", "must be in (0, 1]");
  require(std::isfinite(min_dynamic_speed) && min_dynamic_speed >= 0.0, "min_dynamic_speed",
          "must be >= 0 [m/s]");
  require(std::isfinite(mahalanobis_threshold) && mahalanobis_threshold >= 0.0, "mahalanobis_threshold",
          "must be >= 0");
  require(occupied_threshold > 0.0 && occupied_threshold <= 1.0, "occupied_threshold", "must be in (0, 1]");
  require(threads >= 0 && threads <= 256, "threads", "must be in [0, 256] (0 = all cores)");
  sensor_model.validate();
}

void ParticleArrays::resize(std::size_t n)
{
  x.resize(n);
  y.resize(n);
  vx.resize(n);
  vy.resize(n);
  weight.resize(n);
  cell.resize(n);
}

DynamicGridFilter::DynamicGridFilter(const DynamicGridConfig& config)
    : config_((config.validate(), config)), parallel_(config.threads), sensor_model_(config.sensor_model)
{
  geometry_.width = config_.width;
  geometry_.height = config_.height;
  geometry_.resolution = config_.resolution;
  const std::size_t cells = geometry_.cellCount();
  for (auto* v : {&pred_dynamic_,
                  &from_dynamic_static_,
                  &from_dynamic_unknown_,
                  &newborn_,
                  &persistent_factor_,
                  &stat_w_,
                  &stat_vx_,
                  &stat_vy_,
                  &stat_vxx_,
                  &stat_vyy_,
                  &vacated_share_,
                  &start_share_,
                  &propagated_share_,
                  &left_vx_,
                  &left_vy_,
                  &left_var_x_,
                  &left_var_y_,
                  &source_vx_,
                  &source_vy_,
                  &source_var_x_,
                  &source_var_y_,
                  &source_weight_,
                  &motion_evidence_,
                  &evidence_scratch_})
  {
    v->resize(cells);
  }
  const auto n = static_cast<std::size_t>(config_.particle_count);
  particles_.resize(n);
  resampled_.resize(n);
  const auto births = static_cast<std::size_t>(std::ceil(config_.birth_fraction * n));
  birth_cell_.resize(births);
  for (auto* v : {&birth_x_, &birth_y_, &birth_vx_, &birth_vy_, &birth_w_})
  {
    v->resize(births);
  }
  occupied_mask_.assign(cells, 0);
  previous_mask_.assign(cells, 0);
  ages_.assign(cells, kAgesNever);
  age_scratch_.assign(cells, kAgesNever);
  vacated_count_.assign(
      static_cast<std::size_t>(geometry_.width + 1) * static_cast<std::size_t>(geometry_.height + 1), 0);
  bucket_cols_ = (geometry_.width + kBucket - 1) / kBucket;
  bucket_rows_ = (geometry_.height + kBucket - 1) / kBucket;
  bucket_start_.assign(static_cast<std::size_t>(bucket_cols_) * static_cast<std::size_t>(bucket_rows_) + 1,
                       0);
  normalTable();
  const std::size_t blocks = std::max({blockCount(n, kParticleBlock) + blockCount(births, kParticleBlock),
                                       blockCount(static_cast<std::size_t>(geometry_.height), kRowBlock)});
  block_sum_.resize(blocks);
  block_start_.resize(blocks + 1);
  block_candidates_.resize(blockCount(static_cast<std::size_t>(geometry_.height), kRowBlock));
  band_particles_.resize(blockCount(static_cast<std::size_t>(geometry_.height), kRowBlock));
  block_counts_.resize(blockCount(n, kParticleBlock) * band_particles_.size());
  part_band_ = {0, band_particles_.size()};
  reset();
}

void DynamicGridFilter::reset()
{
  const auto prior_var = static_cast<float>(config_.birth_velocity_sigma * config_.birth_velocity_sigma);
  cells_.reset(geometry_.cellCount(), prior_var);
  std::fill(particles_.weight.begin(), particles_.weight.end(), 0.0F);
  std::fill(particles_.cell.begin(), particles_.cell.end(), -1);
  occupancy_.assign(geometry_.cellCount(), 0.5F);
  std::fill(occupied_mask_.begin(), occupied_mask_.end(), 0);
  std::fill(previous_mask_.begin(), previous_mask_.end(), 0);
  std::fill(ages_.begin(), ages_.end(), kAgesNever);
  std::fill(motion_evidence_.begin(), motion_evidence_.end(), 0.0F);
  vacated_.clear();
  have_previous_ = false;
  cycle_ = 0;
  initialised_ = false;
}

void DynamicGridFilter::placeGrid(const Eigen::Isometry3d& world_from_sensor, std::int64_t& col,
                                  std::int64_t& row) const
{
  // Eq. 1: centre = sensor + lookahead * heading, heading = the sensor x axis on the ground.
  const Eigen::Vector3d x_axis = world_from_sensor.linear().col(0);
  const double yaw = std::atan2(x_axis.y(), x_axis.x());
  const double cx = world_from_sensor.translation().x() + config_.lookahead * std::cos(yaw);
  const double cy = world_from_sensor.translation().y() + config_.lookahead * std::sin(yaw);
  col = static_cast<std::int64_t>(std::llround(cx / config_.resolution - 0.5 * config_.width));
  row = static_cast<std::int64_t>(std::llround(cy / config_.resolution - 0.5 * config_.height));
}

DynamicGridCycle DynamicGridFilter::update(const PointCloudView& cloud,
                                           const Eigen::Isometry3d& world_from_sensor, double stamp)
{
  using Clock = std::chrono::steady_clock;
  const Clock::time_point t_start = Clock::now();
  DynamicGridCycle cycle;
  resetAfterTimeJump(stamp, cycle);
  const bool first = !initialised_;
  const double dt = first ? 0.0 : stamp - last_stamp_;
  cycle.dt = dt;

  // 1. Ego motion: move the grid by whole cells; particles keep their fixed-frame position.
  moveGrid(world_from_sensor, first, cycle);
  initialised_ = true;
  last_stamp_ = stamp;
  last_received_stamp_ = stamp;
  ground_z_ = world_from_sensor.translation().z() - config_.sensor_model.sensor_height;
  sensor_origin_ = world_from_sensor.translation();

  // 2. Inverse sensor model: p_o per cell; the cells the scan shows vacated or appearing.
  const Clock::time_point t_model = Clock::now();
  if (cloud.size() > 0)
  {
    cycle.sensor = sensor_model_.compute(cloud, world_from_sensor, geometry_, occupancy_, parallel_);
  }
  else
  {
    occupancy_.assign(geometry_.cellCount(), 0.5F);
  }
  const Clock::time_point t_model_end = Clock::now();
  findMotionCells(first, static_cast<float>(dt));

  // 3. Particle prediction and the dynamic mass it carries into each cell (eq. 3-4). The first
  // scan has no motion; its transitions use one transition_period so that it counts.
  const double dt_transition = first ? config_.transition_period : dt;
  clearPredictedMasses();
  if (!first)
  {
    const Row rd = scaledRow({config_.eps_dynamic_to_static, config_.eps_dynamic_to_unknown, 0.0},
                             dt_transition, config_.transition_period);
    predictParticles(static_cast<float>(dt), rd.stay, rd.to[0], rd.to[1]);
  }

  // 4-5. Per cell: predicted masses (eq. 5), Bayes update (eq. 6), persistent/newborn split (eq. 7).
  updateCells(dt_transition);

  // 6. Persistent weights rescaled so that they sum to the persistent posterior mass (eq. 8);
  // 7. velocity mean and variance given D per cell from the persistent particles (eq. 9).
  accumulateVelocities(first);
  estimateCellVelocities();

  // Rigid-object prior: static mass on the velocity line of moving cells starts moving.
  if (config_.motion_window > 0.0 && config_.propagation_rate > 0.0)
  {
    propagateMotion(static_cast<float>(dt_transition));
  }

  // 8-9. Birth in proportion to the newborn mass, resampling.
  cycle.particles_in_use = birthAndResample(cycle.particles_born, static_cast<float>(dt));
  ++cycle_;
  const Clock::time_point t_end = Clock::now();
  cycle.sensor_model_seconds = std::chrono::duration<double>(t_model_end - t_model).count();
  cycle.filter_seconds = std::chrono::duration<double>((t_end - t_start) - (t_model_end - t_model)).count();
  return cycle;
}

void DynamicGridFilter::cellGroundHeights(std::vector<float>& z) const
{
  z.assign(geometry_.cellCount(), std::numeric_limits<float>::quiet_NaN());
  if (!initialised_)
  {
    return;
  }
  const auto oz = static_cast<float>(sensor_origin_.z());
  forRowBlocks(
      [&](std::size_t, int r0, int r1)
      {
        for (int row = r0; row < r1; ++row)
        {
          const auto dy = static_cast<float>(geometry_.cellCenterY(row) - sensor_origin_.y());
          for (int col = 0; col < geometry_.width; ++col)
          {
            const auto dx = static_cast<float>(geometry_.cellCenterX(col) - sensor_origin_.x());
            z[geometry_.index(row, col)] = oz + sensor_model_.groundHeightAt(dx, dy);
          }
        }
      });
}

void DynamicGridFilter::skipScan(double stamp)
{
  if (initialised_ && stamp > last_received_stamp_)
  {
    last_received_stamp_ = stamp;
  }
}

void DynamicGridFilter::resetAfterTimeJump(double stamp, DynamicGridCycle& cycle)
{
  if (!initialised_)
  {
    return;
  }
  const double back = last_stamp_ - stamp;
  const double gap = stamp - last_received_stamp_;
  if (back > 0.0 || gap > config_.max_time_gap)
  {
    cycle.reset = true;
    cycle.reset_reason = back > 0.0 ? "time jumped backwards by " + std::to_string(back) + " s"
                                    : "gap of " + std::to_string(gap) +
                                          " s since the last scan received exceeds max_time_gap (" +
                                          std::to_string(config_.max_time_gap) + " s)";
    reset();
  }
}

void DynamicGridFilter::moveGrid(const Eigen::Isometry3d& world_from_sensor, bool first,
                                 DynamicGridCycle& cycle)
{
  std::int64_t col = 0;
  std::int64_t row = 0;
  placeGrid(world_from_sensor, col, row);
  if (first)
  {
    geometry_.origin_col = col;
    geometry_.origin_row = row;
    return;
  }
  cycle.shift_cols = col - geometry_.origin_col;
  cycle.shift_rows = row - geometry_.origin_row;
  const auto prior_var = static_cast<float>(config_.birth_velocity_sigma * config_.birth_velocity_sigma);
  shiftCells(cells_, geometry_.width, geometry_.height, cycle.shift_cols, cycle.shift_rows, prior_var,
             parallel_);
  geometry_.origin_col = col;
  geometry_.origin_row = row;
  shiftScanMemory(cycle.shift_cols, cycle.shift_rows);
  shiftParticles(cycle.shift_cols, cycle.shift_rows);
}

void DynamicGridFilter::shiftScanMemory(std::int64_t shift_cols, std::int64_t shift_rows)
{
  // The occupied mask of the last scan, moved like the cells: the previous scan's mask; the ages
  // and the motion evidence move with the cells too (cells entering the grid: never seen).
  const int w = geometry_.width;
  const int h = geometry_.height;
  if (shift_cols == 0 && shift_rows == 0)
  {
    previous_mask_ = occupied_mask_;
    return;
  }
  forRowBlocks(
      [&](std::size_t, int r_begin, int r_end)
      {
        for (int r = r_begin; r < r_end; ++r)
        {
          const std::int64_t src_r = r + shift_rows;
          for (int c = 0; c < w; ++c)
          {
            const std::int64_t src_c = c + shift_cols;
            const std::size_t dst = geometry_.index(r, c);
            if (src_r >= 0 && src_r < h && src_c >= 0 && src_c < w)
            {
              const std::size_t src = static_cast<std::size_t>(src_r) * static_cast<std::size_t>(w) +
                                      static_cast<std::size_t>(src_c);
              previous_mask_[dst] = occupied_mask_[src];
              age_scratch_[dst] = ages_[src];
              evidence_scratch_[dst] = motion_evidence_[src];
            }
            else
            {
              previous_mask_[dst] = 0;
              age_scratch_[dst] = kAgesNever;
              evidence_scratch_[dst] = 0.0F;
            }
          }
        }
      });
  std::swap(ages_, age_scratch_);
  std::swap(motion_evidence_, evidence_scratch_);
}

void DynamicGridFilter::shiftParticles(std::int64_t shift_cols, std::int64_t shift_rows)
{
  const float sx = static_cast<float>(static_cast<double>(shift_cols) * geometry_.resolution);
  const float sy = static_cast<float>(static_cast<double>(shift_rows) * geometry_.resolution);
  if (sx == 0.0F && sy == 0.0F)
  {
    return;
  }
  const std::size_t n = particles_.size();
  parallel_.run(blockCount(n, kParticleBlock),
                [&](std::size_t b)
                {
                  const std::size_t end = std::min(n, (b + 1) * kParticleBlock);
                  for (std::size_t i = b * kParticleBlock; i < end; ++i)
                  {
                    particles_.x[i] -= sx;
                    particles_.y[i] -= sy;
                  }
                });
}

}  // namespace grid_vision_fusion
