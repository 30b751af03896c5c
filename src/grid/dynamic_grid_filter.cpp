// CMCDOT-style dynamic occupancy grid filter (a documented reconstruction,
// doc/grid_filter.md, whose equation numbers the comments below refer to).
#include "grid_vision_fusion/grid/dynamic_grid_filter.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace grid_vision_fusion
{
namespace
{
/// start[b] = sum[0] + … + sum[b − 1] for b = 0 … blocks, summed in block order (the same bits
/// whatever the thread count that computed the block sums); returns the total, start[blocks].
double blockStarts(const std::vector<double>& sum, std::size_t blocks, std::vector<double>& start)
{
  start[0] = 0.0;
  for (std::size_t b = 0; b < blocks; ++b)
  {
    start[b + 1] = start[b] + sum[b];
  }
  return start[blocks];
}

constexpr int kNormalTableBits = 16;
constexpr std::size_t kNormalTableSize = std::size_t{1} << kNormalTableBits;
constexpr int kBucket = 8;  // vacated cells are bucketed in squares of kBucket x kBucket cells
// Motion evidence (doc/grid_filter.md, "Motion evidence").
constexpr float kClearlyFree = 0.25F;           // p_o at or below which a cell is seen clearly free
constexpr float kBelievedOccupied = 0.6F;       // P(S) + P(D) of a cell believed occupied
constexpr float kBelievedFree = 0.6F;           // P(E) of a cell believed free
constexpr float kEvidenceGate = 0.3F;           // evidence from which a cell counts as moving
constexpr float kSignificantMotion = 9.0F;      // m^2 of a propagation source (3 standard deviations)
constexpr float kMinVelocityVariance = 0.01F;   // [m^2/s^2] floor of var_x, var_y in m^2
constexpr float kInheritVarianceFloor = 0.25F;  // [m^2/s^2] floor of an inherited velocity variance
constexpr std::uint16_t kAgesNever = 0xFFFF;    // both ages saturated: never (or not for 255 scans)
// Blocks of the parallel passes (doc/grid_filter.md, "Determinism"): fixed sizes, independent of
// the thread count, so every block does the same work and draws the same random numbers.
constexpr std::size_t kParticleBlock = 4096;  // particles per block
constexpr int kRowBlock = 8;                  // grid rows per block (and per band of the particle sort)
// Passes that draw random numbers: part of the seed of each block's stream.
enum Pass : std::uint32_t
{
  kPassCycle = 1,    // the offsets of the two systematic samplings
  kPassPredict = 2,  // process noise
  kPassBirth = 3,    // newborn particles
};

// Significance of a mean velocity: vx^2 / var_x + vy^2 / var_y (variances floored).
inline float velocitySignificance(float vx, float vy, float var_x, float var_y)
{
  return vx * vx / std::max(var_x, kMinVelocityVariance) + vy * vy / std::max(var_y, kMinVelocityVariance);
}

// Probability of an event of probability `per_period` within transition_period, over dt.
float perInterval(double per_period, double dt, double period)
{
  if (per_period <= 0.0 || dt <= 0.0)
  {
    return 0.0F;
  }
  return static_cast<float>(1.0 - std::pow(1.0 - per_period, dt / period));
}

// Standard normal quantiles at the centres of 2^16 equal-probability slices: a 16-bit random
// index gives a normal sample (tails cut at +-4.3 sigma), a deterministic and fast sampler.
const std::vector<float>& normalTable()
{
  static const std::vector<float> table = []
  {
    std::vector<float> t(kNormalTableSize);
    for (std::size_t i = 0; i < kNormalTableSize; ++i)
    {
      t[i] = static_cast<float>(inverseNormalCdf((static_cast<double>(i) + 0.5) / kNormalTableSize));
    }
    return t;
  }();
  return table;
}

inline float normalSample(BlockRandom& rng)
{
  return normalTable()[rng.bits16()];
}

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

// Off-diagonal transition probabilities of one row scaled to dt (eq. 2): the probability of
// leaving the state, q = sum(eps), becomes 1 - (1 - q)^(dt / T), shared in the same proportions.
struct Row
{
  float stay = 1.0F;
  std::array<float, 3> to{};
};

Row scaledRow(std::array<double, 3> eps, double dt, double period)
{
  Row row;
  const double q = eps[0] + eps[1] + eps[2];
  if (q <= 0.0 || dt <= 0.0)
  {
    return row;
  }
  const double q_dt = 1.0 - std::pow(1.0 - q, dt / period);
  for (std::size_t k = 0; k < 3; ++k)
  {
    row.to[k] = static_cast<float>(eps[k] / q * q_dt);
  }
  row.stay = static_cast<float>(1.0 - q_dt);
  return row;
}

// The constants of one cycle's cell update (eq. 5-7): the rows of the states S, E, U scaled to dt,
// the motion-driven shares and 1 / the information of a clear measurement.
struct CellTransitions
{
  Row rs;
  Row re;
  Row ru;
  float u_to_d = 0.0F;           // unknown_to_dynamic_by_motion
  float start = 0.0F;            // static_to_dynamic_by_motion within dt
  float inv_information = 0.0F;  // 1 / max(p_occupied - 1/2, 1/2 - p_free)
};

CellTransitions cellTransitions(const DynamicGridConfig& config, double dt_transition)
{
  CellTransitions t;
  t.rs = scaledRow({config.eps_static_to_dynamic, config.eps_static_to_unknown, 0.0}, dt_transition,
                   config.transition_period);
  t.re = scaledRow({config.eps_free_to_static, config.eps_free_to_dynamic, config.eps_free_to_unknown},
                   dt_transition, config.transition_period);
  t.ru = scaledRow({config.eps_unknown_to_static, config.eps_unknown_to_dynamic, config.eps_unknown_to_free},
                   dt_transition, config.transition_period);
  t.inv_information = 1.0F / static_cast<float>(std::max(config.sensor_model.p_occupied - 0.5,
                                                         0.5 - config.sensor_model.p_free));
  t.u_to_d = static_cast<float>(config.unknown_to_dynamic_by_motion);
  t.start = perInterval(config.static_to_dynamic_by_motion, dt_transition, config.transition_period);
  return t;
}

// A cell's masses predicted to this scan (eq. 5), before the mass that left with its particles.
struct PredictedMasses
{
  float s_pred;
  float d_persistent;  // brought by the particles that arrived (eq. 4)
  float d_started;     // static mass that started moving
  float d_newborn;     // d_started included
  float e_pred;
  float u_pred;
};

// Eq. 5 for a cell of masses (s, e, u) measured p_o = po, with motion evidence mu and measurement
// information lambda; d_persistent, from_static, from_unknown: what its particles brought (eq. 4).
inline PredictedMasses predictMasses(const CellTransitions& t, float s, float e, float u, float po, float mu,
                                     float lambda, float d_persistent, float from_static, float from_unknown)
{
  const Row& rs = t.rs;
  const Row& re = t.re;
  const Row& ru = t.ru;
  // Motion evidence mu moves the unknown-to-static share to dynamic (occupancy appearing next
  // to a vacated cell, or in a cell seen free, has moved there), and lets the static mass of
  // a cell measured occupied start moving (a static object does not leave a cell in view).
  const float u_s = lambda * ru.to[0] * (1.0F - t.u_to_d * mu);
  const float u_d = lambda * (ru.to[1] + ru.to[0] * t.u_to_d * mu);
  const float u_e = lambda * ru.to[2];
  const float s_start = po > 0.5F ? std::min(t.start * mu, rs.stay) : 0.0F;
  PredictedMasses m;
  m.s_pred = s * (rs.stay - s_start) + e * re.to[0] + u * u_s + from_static;
  m.d_persistent = d_persistent;
  m.d_started = s * s_start;
  m.d_newborn = s * rs.to[0] + m.d_started + e * re.to[1] + u * u_d;
  m.e_pred = e * re.stay + u * u_e;
  m.u_pred = s * rs.to[1] + e * re.to[2] + u * (1.0F - u_s - u_d - u_e) + from_unknown;
  return m;
}

// The resampling's items of block b (the n particles in particle_blocks blocks, then the born
// newborn ones): [begin, end) of the particles' or the newborn ones' arrays.
void itemRange(std::size_t b, std::size_t particle_blocks, std::size_t n, std::size_t born,
               std::size_t& begin, std::size_t& end)
{
  const std::size_t size = b < particle_blocks ? n : born;
  begin = (b < particle_blocks ? b : b - particle_blocks) * kParticleBlock;
  end = std::min(size, begin + kParticleBlock);
}
}  // namespace

// A systematic sampling: samples at (u + k) * step, k = 0, 1, ... (offset u in [0, 1)), at most
// `limit` of them. below(k, C): sample k lies below the cumulative mass C; count(C): the number
// of samples below C. Both use the same comparison, so that counting and stepping agree.
struct DynamicGridFilter::SystematicSamples
{
  double u;
  double step;
  std::size_t limit;

  bool below(std::size_t k, double cumulative) const
  {
    return (u + static_cast<double>(k)) * step < cumulative;
  }

  std::size_t count(double cumulative) const
  {
    const double estimate = std::ceil(cumulative / step - u);
    std::size_t k =
        estimate > 0.0 ? static_cast<std::size_t>(std::min(estimate, static_cast<double>(limit))) : 0;
    while (k > 0 && !below(k - 1, cumulative))
    {
      --k;
    }
    while (k < limit && below(k, cumulative))
    {
      ++k;
    }
    return k;
  }

  /// Advances `k` past the samples below `cumulative`, up to `end`.
  std::size_t advance(std::size_t k, double cumulative, std::size_t end) const
  {
    while (k < end && below(k, cumulative))
    {
      ++k;
    }
    return k;
  }
};

double inverseNormalCdf(double p)
{
  static const double a[] = {-3.969683028665376e+01, 2.209460984245205e+02,  -2.759285104469687e+02,
                             1.383577518672690e+02,  -3.066479806614716e+01, 2.506628277459239e+00};
  static const double b[] = {-5.447609879822406e+01, 1.615858368580409e+02, -1.556989798598866e+02,
                             6.680131188771972e+01, -1.328068155288572e+01};
  static const double c[] = {-7.784894002430293e-03, -3.223964580411365e-01, -2.400758277161838e+00,
                             -2.549732539343734e+00, 4.374664141464968e+00,  2.938163982698783e+00};
  static const double d[] = {7.784695709041462e-03, 3.224671290700398e-01, 2.445134137142996e+00,
                             3.754408661907416e+00};
  constexpr double kLow = 0.02425;
  if (p <= 0.0 || p >= 1.0)
  {
    throw std::domain_error("inverseNormalCdf: p must be in (0, 1)");
  }
  if (p < kLow)
  {
    const double q = std::sqrt(-2.0 * std::log(p));
    return (((((c[0] * q + c[1]) * q + c[2]) * q + c[3]) * q + c[4]) * q + c[5]) /
           ((((d[0] * q + d[1]) * q + d[2]) * q + d[3]) * q + 1.0);
  }
  if (p > 1.0 - kLow)
  {
    return -inverseNormalCdf(1.0 - p);
  }
  const double q = p - 0.5;
  const double r = q * q;
  return (((((a[0] * r + a[1]) * r + a[2]) * r + a[3]) * r + a[4]) * r + a[5]) * q /
         (((((b[0] * r + b[1]) * r + b[2]) * r + b[3]) * r + b[4]) * r + 1.0);
}

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

void DynamicGridFilter::predictParticles(float dt, float keep, float to_static, float to_unknown)
{
  // Eq. 3: constant velocity with a random acceleration a ~ N(0, sigma_a^2) per axis:
  // x += v dt + a dt^2 / 2, v += a dt.
  const float sa = static_cast<float>(config_.acceleration_sigma);
  const float res = static_cast<float>(geometry_.resolution);
  const float w_lim = static_cast<float>(geometry_.width) * res;
  const float h_lim = static_cast<float>(geometry_.height) * res;
  const float max_v2 = static_cast<float>(config_.max_speed * config_.max_speed);
  const float inv_res = 1.0F / res;
  ParticleArrays& p = particles_;
  const std::size_t n = p.size();
  // Eq. 4: the particle keeps the fraction `keep` of its mass as dynamic; the rest becomes
  // static or unknown mass of the cell it arrives in. One thread adds each particle's masses to
  // its cell as it moves (particle order); several move the particles in blocks, counting them
  // per band of rows, then add the masses per part of the grid (forParticlesByCellPart): the
  // same sums.
  const bool serial = parallel_.threads() == 1;
  const std::size_t bands = band_particles_.size();
  const auto band_cells = static_cast<std::size_t>(kRowBlock * geometry_.width);
  parallel_.run(blockCount(n, kParticleBlock),
                [&](std::size_t b)
                {
                  BlockRandom rng(config_.seed, cycle_, kPassPredict, b);
                  std::size_t* band_counts = block_counts_.data() + b * bands;
                  if (!serial)
                  {
                    std::fill(band_counts, band_counts + bands, 0);
                  }
                  const std::size_t end = std::min(n, (b + 1) * kParticleBlock);
                  for (std::size_t i = b * kParticleBlock; i < end; ++i)
                  {
                    if (p.weight[i] <= 0.0F)
                    {
                      p.cell[i] = -1;
                      continue;
                    }
                    const float ax = sa * normalSample(rng);
                    const float ay = sa * normalSample(rng);
                    p.x[i] += (p.vx[i] + 0.5F * ax * dt) * dt;
                    p.y[i] += (p.vy[i] + 0.5F * ay * dt) * dt;
                    p.vx[i] += ax * dt;
                    p.vy[i] += ay * dt;
                    if (!(p.x[i] >= 0.0F && p.y[i] >= 0.0F && p.x[i] < w_lim && p.y[i] < h_lim) ||
                        p.vx[i] * p.vx[i] + p.vy[i] * p.vy[i] > max_v2)
                    {
                      p.weight[i] = 0.0F;
                      p.cell[i] = -1;
                      continue;
                    }
                    const int c = std::min(static_cast<int>(p.x[i] * inv_res), geometry_.width - 1);
                    const int r = std::min(static_cast<int>(p.y[i] * inv_res), geometry_.height - 1);
                    const std::size_t cell = geometry_.index(r, c);
                    p.cell[i] = static_cast<std::int32_t>(cell);
                    if (serial)
                    {
                      const float w = p.weight[i];
                      pred_dynamic_[cell] += w * keep;
                      from_dynamic_static_[cell] += w * to_static;
                      from_dynamic_unknown_[cell] += w * to_unknown;
                      p.weight[i] = w * keep;
                    }
                    else
                    {
                      ++band_counts[cell / band_cells];
                    }
                  }
                });
  if (serial)
  {
    return;
  }
  splitCellsByParticles(true);
  forParticlesByCellPart(
      [&](std::size_t i)
      {
        const auto cell = static_cast<std::size_t>(p.cell[i]);
        const float w = p.weight[i];
        pred_dynamic_[cell] += w * keep;
        from_dynamic_static_[cell] += w * to_static;
        from_dynamic_unknown_[cell] += w * to_unknown;
        p.weight[i] = w * keep;
      });
}

void DynamicGridFilter::splitCellsByParticles(bool counted)
{
  // A task that goes through every particle costs a pass over p.cell; one part per thread keeps
  // that to one pass per thread. The split changes with the thread count, the sums do not
  // (forParticlesByCellPart).
  const ParticleArrays& p = particles_;
  const std::size_t n = p.size();
  const std::size_t blocks = blockCount(n, kParticleBlock);
  const std::size_t bands = band_particles_.size();
  const auto band_cells = static_cast<std::int32_t>(kRowBlock * geometry_.width);
  parallel_.run(counted ? 0 : blocks,
                [&](std::size_t b)
                {
                  std::size_t* counts = block_counts_.data() + b * bands;
                  std::fill(counts, counts + bands, 0);
                  const std::size_t end = std::min(n, (b + 1) * kParticleBlock);
                  for (std::size_t i = b * kParticleBlock; i < end; ++i)
                  {
                    if (p.cell[i] >= 0)
                    {
                      ++counts[static_cast<std::size_t>(p.cell[i] / band_cells)];
                    }
                  }
                });
  std::size_t total = 0;
  for (std::size_t band = 0; band < bands; ++band)
  {
    std::size_t count = 0;
    for (std::size_t b = 0; b < blocks; ++b)
    {
      count += block_counts_[b * bands + band];
    }
    band_particles_[band] = count;
    total += count;
  }
  const auto parts = static_cast<std::size_t>(parallel_.threads());
  part_band_.assign(parts + 1, bands);
  part_band_[0] = 0;
  std::size_t cumulative = 0;
  std::size_t part = 1;
  for (std::size_t band = 0; band < bands && part < parts; ++band)
  {
    cumulative += band_particles_[band];
    while (part < parts && cumulative * parts >= total * part)
    {
      part_band_[part++] = band + 1;
    }
  }
}

template <typename F>
void DynamicGridFilter::forParticlesByCellPart(const F& f) const
{
  const std::int32_t* cell = particles_.cell.data();
  const std::size_t n = particles_.size();
  const auto band_cells = static_cast<std::int32_t>(kRowBlock * geometry_.width);
  parallel_.run(part_band_.size() - 1,
                [&](std::size_t part)
                {
                  const auto begin = static_cast<std::int32_t>(part_band_[part]) * band_cells;
                  const auto end = static_cast<std::int32_t>(part_band_[part + 1]) * band_cells;
                  for (std::size_t i = 0; i < n; ++i)
                  {
                    if (cell[i] >= begin && cell[i] < end)
                    {
                      f(i);
                    }
                  }
                });
}

template <typename F>
void DynamicGridFilter::forRowBlocks(const F& f) const
{
  const int h = geometry_.height;
  parallel_.run(blockCount(static_cast<std::size_t>(h), kRowBlock),
                [&](std::size_t b)
                {
                  const int r0 = static_cast<int>(b) * kRowBlock;
                  f(b, r0, std::min(h, r0 + kRowBlock));
                });
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

void DynamicGridFilter::clearPredictedMasses()
{
  forRowBlocks(
      [&](std::size_t, int r_begin, int r_end)
      {
        const auto begin = static_cast<std::ptrdiff_t>(geometry_.index(r_begin, 0));
        const auto end = static_cast<std::ptrdiff_t>(geometry_.index(r_end, 0));
        for (GridArray<float>* v : {&pred_dynamic_, &from_dynamic_static_, &from_dynamic_unknown_})
        {
          std::fill(v->begin() + begin, v->begin() + end, 0.0F);
        }
      });
}

void DynamicGridFilter::updateCells(double dt_transition)
{
  const CellTransitions t = cellTransitions(config_, dt_transition);
  const bool evidence = config_.motion_window > 0.0;
  const auto gw = static_cast<std::size_t>(geometry_.width);
  forRowBlocks(
      [&](std::size_t, int r_begin, int r_end)
      {
        for (std::size_t c = static_cast<std::size_t>(r_begin) * gw; c < static_cast<std::size_t>(r_end) * gw;
             ++c)
        {
          const float s = cells_.p_static[c];
          const float po = occupancy_[c];
          const float mu = evidence ? motion_evidence_[c] : 0.0F;
          // Unknown becomes known only through an observation: the U -> S/D/E transitions are scaled
          // by the information of this scan's measurement, lambda = |p_o - 1/2| / (p_occ - 1/2)
          // (1 for a cell seen occupied or free, 0 for an unobserved one, whose U mass then stays U
          // instead of drifting to a stale static/free prior while it is shadowed).
          const float lambda = std::min(std::fabs(po - 0.5F) * t.inv_information, 1.0F);
          PredictedMasses m =
              predictMasses(t, s, cells_.p_free[c], cells_.p_unknown[c], po, mu, lambda, pred_dynamic_[c],
                            from_dynamic_static_[c], from_dynamic_unknown_[c]);
          const float total = m.s_pred + m.d_persistent + m.d_newborn + m.e_pred + m.u_pred;
          float d_vacated = 0.0F;
          if (total < 1.0F)
          {
            // The mass that moved out of the cell with its particles: part of it newborn dynamic
            // mass (vacated_to_dynamic), the rest unknown.
            const float hole = 1.0F - total;
            if (config_.vacated_to_dynamic)
            {
              d_vacated = vacatedToDynamic(c, s, lambda, hole);
              m.d_newborn += d_vacated;
              m.u_pred += (1.0F - lambda) * hole;
            }
            else
            {
              m.u_pred += hole;  // unknown now
            }
          }
          vacated_share_[c] = m.d_newborn > 0.0F ? d_vacated / m.d_newborn : 0.0F;
          start_share_[c] = m.d_newborn > 0.0F ? m.d_started / m.d_newborn : 0.0F;
          propagated_share_[c] = 0.0F;
          const float ls = po * m.s_pred;
          const float ldp = po * m.d_persistent;
          const float ldn = po * m.d_newborn;
          const float le = (1.0F - po) * m.e_pred;
          const float lu = 0.5F * m.u_pred;
          const float z = ls + ldp + ldn + le + lu;
          const float inv_z = 1.0F / z;
          cells_.p_static[c] = ls * inv_z;
          cells_.p_dynamic[c] = (ldp + ldn) * inv_z;
          cells_.p_free[c] = le * inv_z;
          cells_.p_unknown[c] = lu * inv_z;
          persistent_factor_[c] = po * inv_z;
          newborn_[c] = po > 0.5F ? ldn * inv_z : 0.0F;
        }
        // The sums of step 7 start from zero. Zeroed here, per block after its cells: zeroing them
        // with the three arrays before the prediction measured 8.2 instead of 7.0 ms per cycle on
        // 2 threads (bench_dynamic_grid).
        const auto begin = static_cast<std::ptrdiff_t>(static_cast<std::size_t>(r_begin) * gw);
        const auto end = static_cast<std::ptrdiff_t>(static_cast<std::size_t>(r_end) * gw);
        for (GridArray<float>* v : {&stat_w_, &stat_vx_, &stat_vy_, &stat_vxx_, &stat_vyy_})
        {
          std::fill(v->begin() + begin, v->begin() + end, 0.0F);
        }
      });
}

inline float DynamicGridFilter::vacatedToDynamic(std::size_t c, float s, float lambda, float hole)
{
  // In an observed cell the share q = D / (S + D) (1 - exp(-m^2/2)) of the hole -- how much the
  // occupant was believed to move, times the significance m^2 of the velocity that left -- is the
  // next part of the moving object (newborn dynamic mass with that velocity), the rest of the
  // observed part is left to the measurement (renormalised away); unobserved, it becomes unknown.
  float d_vacated = 0.0F;
  const float occupied = s + cells_.p_dynamic[c];
  const float moving_share = occupied > 0.0F ? cells_.p_dynamic[c] / occupied : 0.0F;
  if (lambda > 0.0F && moving_share > 0.0F)  // else 0: no exp for most cells
  {
    const float m2 = velocitySignificance(cells_.vx[c], cells_.vy[c], cells_.v_var_x[c], cells_.v_var_y[c]);
    d_vacated = lambda * hole * moving_share * (1.0F - std::exp(-0.5F * m2));
  }
  left_vx_[c] = cells_.vx[c];
  left_vy_[c] = cells_.vy[c];
  left_var_x_[c] = cells_.v_var_x[c];
  left_var_y_[c] = cells_.v_var_y[c];
  return d_vacated;
}

void DynamicGridFilter::accumulateVelocities(bool first)
{
  // Per cell sums in particle order, per part of the grid (the split of the prediction: the
  // cells have not changed since).
  ParticleArrays& p = particles_;
  auto accumulate = [&](std::size_t i)
  {
    const std::int32_t ci = p.cell[i];
    if (ci < 0)
    {
      return;
    }
    const auto c = static_cast<std::size_t>(ci);
    const float w = p.weight[i] * persistent_factor_[c];
    p.weight[i] = w;
    const float vx = p.vx[i];
    const float vy = p.vy[i];
    stat_w_[c] += w;
    stat_vx_[c] += w * vx;
    stat_vy_[c] += w * vy;
    stat_vxx_[c] += w * vx * vx;
    stat_vyy_[c] += w * vy * vy;
  };
  if (first && parallel_.threads() > 1)
  {
    splitCellsByParticles(false);  // no prediction on the first scan
  }
  forParticlesByCellPart(accumulate);
}

void DynamicGridFilter::estimateCellVelocities()
{
  const auto prior_var = static_cast<float>(config_.birth_velocity_sigma * config_.birth_velocity_sigma);
  const auto gw = static_cast<std::size_t>(geometry_.width);
  forRowBlocks(
      [&](std::size_t, int r_begin, int r_end)
      {
        for (std::size_t c = static_cast<std::size_t>(r_begin) * gw; c < static_cast<std::size_t>(r_end) * gw;
             ++c)
        {
          const float w = stat_w_[c];
          if (w > 1e-12F)
          {
            const float mx = stat_vx_[c] / w;
            const float my = stat_vy_[c] / w;
            cells_.vx[c] = mx;
            cells_.vy[c] = my;
            cells_.v_var_x[c] = std::max(stat_vxx_[c] / w - mx * mx, 0.0F);
            cells_.v_var_y[c] = std::max(stat_vyy_[c] / w - my * my, 0.0F);
          }
          else
          {
            cells_.vx[c] = 0.0F;
            cells_.vy[c] = 0.0F;
            cells_.v_var_x[c] = prior_var;
            cells_.v_var_y[c] = prior_var;
          }
        }
      });
}

void DynamicGridFilter::findMotionCells(bool first, float dt)
{
  // Vacated cell: what occupied it has moved (a static object does not leave a cell that stays
  // in view). Appearing cell (motion-driven birth): measured occupied now, not in the previous
  // scan. With motion_window = 0 (the previous definitions): occupied p_o > 1/2 in the previous
  // scan, free p_o < 1/2 now. With a window of W scans: held obstacle points within the last W
  // scans, clearly free now (p_o <= 1/4) and believed occupied (P(S) + P(D) >= 0.6); the cells
  // that hold obstacle points are the occupied mask. Vacated cells are bucketed (counting sort)
  // for the search of motionVelocity().
  const bool evidence = config_.motion_window > 0.0;
  const int window =
      evidence
          ? std::max(1, static_cast<int>(std::ceil(config_.motion_window / config_.transition_period - 1e-9)))
          : 0;
  const auto p_hit = static_cast<float>(config_.sensor_model.p_occupied);
  const bool birth =
      !first && have_previous_ && config_.birth_motion_speed > 0.0 && config_.birth_motion_fraction > 0.0;
  vacated_.clear();
  if ((evidence && !first) || birth)
  {
    collectVacatedCells(evidence && !first, window);
  }
  bucketVacatedCells();
  if (evidence)
  {
    // Motion evidence: 1 in a cell that appeared (holds obstacle points now, was seen clearly
    // free within the window and believed free) or lies within motion_radius of a vacated cell
    // (box count on a summed-area table); otherwise the previous evidence decayed by
    // exp(-dt / motion_memory).
    const bool any_vacated = markVacatedEdges();
    sumVacatedCounts();
    spreadMotionEvidence(dt, any_vacated);
    markAppearedEdges(window, p_hit);
  }
  updateAges(evidence, p_hit);
  have_previous_ = true;
}

void DynamicGridFilter::collectVacatedCells(bool windowed, int window)
{
  // Per block of rows, then concatenated in block order: the cells in increasing order.
  const auto uw = static_cast<std::size_t>(geometry_.width);
  forRowBlocks(
      [&](std::size_t b, int r_begin, int r_end)
      {
        std::vector<std::int32_t>& found = block_candidates_[b];
        found.clear();
        for (std::size_t c = static_cast<std::size_t>(r_begin) * uw; c < static_cast<std::size_t>(r_end) * uw;
             ++c)
        {
          const bool vacated = windowed ? (ages_[c] & 0xFF) < window && occupancy_[c] <= kClearlyFree &&
                                              cells_.p_static[c] + cells_.p_dynamic[c] >= kBelievedOccupied
                                        : previous_mask_[c] && occupancy_[c] < 0.5F;
          if (vacated)
          {
            found.push_back(static_cast<std::int32_t>(c));
          }
        }
      });
  for (const std::vector<std::int32_t>& found : block_candidates_)
  {
    vacated_.insert(vacated_.end(), found.begin(), found.end());
  }
}

void DynamicGridFilter::bucketVacatedCells()
{
  std::fill(bucket_start_.begin(), bucket_start_.end(), 0);
  bucket_cells_.resize(vacated_.size());
  const auto w = static_cast<std::size_t>(geometry_.width);
  auto bucketOf = [&](std::int32_t c)
  {
    const auto uc = static_cast<std::size_t>(c);
    return (uc / w / kBucket) * static_cast<std::size_t>(bucket_cols_) + (uc % w) / kBucket;
  };
  for (std::int32_t c : vacated_)
  {
    ++bucket_start_[bucketOf(c) + 1];
  }
  for (std::size_t b = 1; b < bucket_start_.size(); ++b)
  {
    bucket_start_[b] += bucket_start_[b - 1];
  }
  candidates_.assign(bucket_start_.begin(), bucket_start_.end() - 1);  // fill positions
  for (std::int32_t c : vacated_)
  {
    bucket_cells_[static_cast<std::size_t>(candidates_[bucketOf(c)]++)] = c;
  }
  candidates_.clear();
}

bool DynamicGridFilter::markVacatedEdges()
{
  const int gw = geometry_.width;
  const int gh = geometry_.height;
  const auto stride = static_cast<std::size_t>(gw + 1);
  parallelFill(parallel_, vacated_count_, 0);
  for (std::int32_t c : vacated_)
  {
    vacated_count_[static_cast<std::size_t>(c / gw + 1) * stride + static_cast<std::size_t>(c % gw + 1)] = 1;
  }
  // An isolated vacated cell (no other one among its 8 neighbours) is no evidence: what moves
  // leaves an edge of cells, while sampling artefacts (a sector that misses a surface for one
  // scan) leave single cells.
  isolated_.clear();
  for (std::int32_t c : vacated_)
  {
    const int r = c / gw + 1;
    const int col = c % gw + 1;
    int neighbours = 0;
    for (int dr = -1; dr <= 1; ++dr)
    {
      for (int dc = -1; dc <= 1; ++dc)
      {
        const int rr = r + dr;
        const int cc = col + dc;
        if ((dr != 0 || dc != 0) && rr >= 1 && cc >= 1 && rr <= gh && cc <= gw)
        {
          neighbours += vacated_count_[static_cast<std::size_t>(rr) * stride + static_cast<std::size_t>(cc)];
        }
      }
    }
    if (neighbours == 0)
    {
      isolated_.push_back(static_cast<std::size_t>(r) * stride + static_cast<std::size_t>(col));
    }
  }
  for (std::size_t i : isolated_)
  {
    vacated_count_[i] = 0;
  }
  return isolated_.size() < vacated_.size();
}

void DynamicGridFilter::sumVacatedCounts()
{
  // Integers: exact in any order. Prefix sums along the rows, then along the columns.
  const int gw = geometry_.width;
  const int gh = geometry_.height;
  const auto stride = static_cast<std::size_t>(gw + 1);
  forRowBlocks(
      [&](std::size_t, int r_begin, int r_end)
      {
        for (int r = r_begin + 1; r <= r_end; ++r)
        {
          std::int32_t* row = vacated_count_.data() + static_cast<std::size_t>(r) * stride;
          for (int col = 1; col <= gw; ++col)
          {
            row[col] += row[col - 1];
          }
        }
      });
  constexpr int kColumnBlock = 64;
  parallel_.run(blockCount(static_cast<std::size_t>(gw), kColumnBlock),
                [&](std::size_t b)
                {
                  const int c0 = 1 + static_cast<int>(b) * kColumnBlock;
                  const int c1 = std::min(gw, c0 + kColumnBlock - 1);
                  for (int r = 2; r <= gh; ++r)
                  {
                    std::int32_t* row = vacated_count_.data() + static_cast<std::size_t>(r) * stride;
                    const std::int32_t* above = row - stride;
                    for (int col = c0; col <= c1; ++col)
                    {
                      row[col] += above[col];
                    }
                  }
                });
}

void DynamicGridFilter::spreadMotionEvidence(float dt, bool any_vacated)
{
  const int gw = geometry_.width;
  const int gh = geometry_.height;
  const auto stride = static_cast<std::size_t>(gw + 1);
  const int radius = static_cast<int>(std::lround(config_.motion_radius / geometry_.resolution));
  const float decay = std::exp(-std::max(dt, 0.0F) / static_cast<float>(config_.motion_memory));
  auto count = [&](int r, int col)
  { return vacated_count_[static_cast<std::size_t>(r) * stride + static_cast<std::size_t>(col)]; };
  forRowBlocks(
      [&](std::size_t, int r_begin, int r_end)
      {
        for (int r = r_begin; r < r_end; ++r)
        {
          const int r0 = std::max(0, r - radius);
          const int r1 = std::min(gh, r + radius + 1);
          for (int col = 0; col < gw; ++col)
          {
            const std::size_t c = geometry_.index(r, col);
            float e = decay * motion_evidence_[c];
            if (any_vacated)
            {
              const int c0 = std::max(0, col - radius);
              const int c1 = std::min(gw, col + radius + 1);
              if (count(r1, c1) - count(r0, c1) - count(r1, c0) + count(r0, c0) > 0)
              {
                e = 1.0F;
              }
            }
            motion_evidence_[c] = e;
          }
        }
      });
}

void DynamicGridFilter::markAppearedEdges(int window, float p_hit)
{
  const int gw = geometry_.width;
  const int gh = geometry_.height;
  // An appearing surface that was hit next door in the previous scan has not moved there: a
  // surface on a cell boundary, seen from a changing angle, alternates between the two cells.
  auto previousHitNear = [&](int r, int col)
  {
    for (int rr = std::max(0, r - 1); rr <= std::min(gh - 1, r + 1); ++rr)
    {
      for (int cc = std::max(0, col - 1); cc <= std::min(gw - 1, col + 1); ++cc)
      {
        if (previous_mask_[geometry_.index(rr, cc)])
        {
          return true;
        }
      }
    }
    return false;
  };
  // Appeared cells, which like vacated ones count only with an appeared neighbour (an edge).
  auto appeared = [&](int r, int col)
  {
    const std::size_t c = geometry_.index(r, col);
    return occupancy_[c] >= p_hit && (ages_[c] >> 8) < window && cells_.p_free[c] >= kBelievedFree &&
           !previousHitNear(r, col);
  };
  forRowBlocks(
      [&](std::size_t, int r_begin, int r_end)
      {
        for (int r = r_begin; r < r_end; ++r)
        {
          for (int col = 0; col < gw; ++col)
          {
            const std::size_t c = geometry_.index(r, col);
            if (occupancy_[c] < p_hit || !appeared(r, col))
            {
              continue;
            }
            bool edge = false;
            for (int rr = std::max(0, r - 1); rr <= std::min(gh - 1, r + 1) && !edge; ++rr)
            {
              for (int cc = std::max(0, col - 1); cc <= std::min(gw - 1, col + 1) && !edge; ++cc)
              {
                edge = (rr != r || cc != col) && appeared(rr, cc);
              }
            }
            if (edge)
            {
              motion_evidence_[c] = 1.0F;
            }
          }
        }
      });
}

void DynamicGridFilter::updateAges(bool evidence, float p_hit)
{
  // Scans since the cell last held obstacle points / was seen clearly free (the first for the
  // fusion's centre estimate in every mode, both for the motion evidence).
  const auto uw = static_cast<std::size_t>(geometry_.width);
  forRowBlocks(
      [&](std::size_t, int r_begin, int r_end)
      {
        for (std::size_t c = static_cast<std::size_t>(r_begin) * uw; c < static_cast<std::size_t>(r_end) * uw;
             ++c)
        {
          const int hit_age = occupancy_[c] >= p_hit ? 0 : std::min((ages_[c] & 0xFF) + 1, 255);
          const int free_age = occupancy_[c] <= kClearlyFree ? 0 : std::min((ages_[c] >> 8) + 1, 255);
          ages_[c] = static_cast<std::uint16_t>(hit_age | (free_age << 8));
          occupied_mask_[c] = (evidence ? occupancy_[c] >= p_hit : occupancy_[c] > 0.5F) ? 1 : 0;
        }
      });
}

void DynamicGridFilter::propagateMotion(float dt)
{
  // Sources: measured occupied, P(D) >= 1/2, velocity significance >= 9, motion evidence. Along
  // the source's velocity line, both ways, through occupied cells (P(S) + P(D) >= 1/2; one gap
  // cell allowed), each cell records the strongest source (its P(D)) and its velocity; then the
  // static mass of every such cell measured occupied becomes newborn dynamic mass at the rate
  // propagation_rate (per transition_period) times the source's P(D).
  const std::size_t cells = geometry_.cellCount();
  parallelFill(parallel_, source_weight_, 0.0F);
  const int w = geometry_.width;
  const int h = geometry_.height;
  const int steps = static_cast<int>(std::ceil(config_.propagation_length / geometry_.resolution));
  bool any = false;
  for (std::size_t c = 0; c < cells; ++c)
  {
    const float weight = cells_.p_dynamic[c];
    if (occupancy_[c] <= 0.5F || weight < 0.5F || motion_evidence_[c] < kEvidenceGate)
    {
      continue;
    }
    const float vx = cells_.vx[c];
    const float vy = cells_.vy[c];
    if (velocitySignificance(vx, vy, cells_.v_var_x[c], cells_.v_var_y[c]) < kSignificantMotion)
    {
      continue;
    }
    const float big = std::max(std::fabs(vx), std::fabs(vy));
    const float sx = vx / big;
    const float sy = vy / big;
    const int row0 = static_cast<int>(c / static_cast<std::size_t>(w));
    const int col0 = static_cast<int>(c % static_cast<std::size_t>(w));
    for (const float dir : {-1.0F, 1.0F})
    {
      int gaps = 0;
      for (int k = 1; k <= steps; ++k)
      {
        const int col = col0 + static_cast<int>(std::lround(dir * sx * static_cast<float>(k)));
        const int row = row0 + static_cast<int>(std::lround(dir * sy * static_cast<float>(k)));
        if (col < 0 || row < 0 || col >= w || row >= h)
        {
          break;
        }
        const std::size_t i = geometry_.index(row, col);
        if (cells_.p_static[i] + cells_.p_dynamic[i] < 0.5F)
        {
          if (++gaps > 1)
          {
            break;
          }
          continue;
        }
        gaps = 0;
        if (weight > source_weight_[i])
        {
          source_weight_[i] = weight;
          source_vx_[i] = vx;
          source_vy_[i] = vy;
          source_var_x_[i] = cells_.v_var_x[c];
          source_var_y_[i] = cells_.v_var_y[c];
          any = true;
        }
      }
    }
  }
  if (!any)
  {
    return;
  }
  const float rate = perInterval(config_.propagation_rate, dt, config_.transition_period);
  forRowBlocks(
      [&](std::size_t, int r_begin, int r_end)
      {
        for (std::size_t c = static_cast<std::size_t>(r_begin) * static_cast<std::size_t>(w);
             c < static_cast<std::size_t>(r_end) * static_cast<std::size_t>(w); ++c)
        {
          if (source_weight_[c] <= 0.0F || occupancy_[c] <= 0.5F)
          {
            continue;
          }
          const float moved = rate * source_weight_[c] * cells_.p_static[c];
          const float before = newborn_[c];
          cells_.p_static[c] -= moved;
          cells_.p_dynamic[c] += moved;
          newborn_[c] = before + moved;
          const float keep = before / newborn_[c];
          vacated_share_[c] *= keep;
          start_share_[c] *= keep;
          propagated_share_[c] = moved / newborn_[c];
        }
      });
}

bool DynamicGridFilter::motionVelocity(std::size_t cell, float x, float y, float dt, float& vx, float& vy,
                                       BlockRandom& rng, std::vector<std::int32_t>& candidates) const
{
  if (vacated_.empty() || dt <= 0.0F)
  {
    return false;
  }
  const float res = static_cast<float>(geometry_.resolution);
  const float radius = static_cast<float>(config_.birth_motion_speed) * dt;
  const int w = geometry_.width;
  const int row = static_cast<int>(cell / static_cast<std::size_t>(w));
  const int col = static_cast<int>(cell % static_cast<std::size_t>(w));
  const int reach = static_cast<int>(std::ceil(radius / res)) + 1;
  const float r2 = radius * radius;
  candidates.clear();
  const int b_r0 = std::max(0, (row - reach) / kBucket);
  const int b_r1 = std::min(bucket_rows_ - 1, (row + reach) / kBucket);
  const int b_c0 = std::max(0, (col - reach) / kBucket);
  const int b_c1 = std::min(bucket_cols_ - 1, (col + reach) / kBucket);
  for (int br = b_r0; br <= b_r1; ++br)
  {
    for (int bc = b_c0; bc <= b_c1; ++bc)
    {
      const std::size_t b = static_cast<std::size_t>(br) * static_cast<std::size_t>(bucket_cols_) +
                            static_cast<std::size_t>(bc);
      for (std::int32_t k = bucket_start_[b]; k < bucket_start_[b + 1]; ++k)
      {
        const std::int32_t v = bucket_cells_[static_cast<std::size_t>(k)];
        const float dr = static_cast<float>(v / w - row) * res;
        const float dc = static_cast<float>(v % w - col) * res;
        if (dr * dr + dc * dc <= r2)
        {
          candidates.push_back(v);
        }
      }
    }
  }
  if (candidates.empty())
  {
    return false;
  }
  const auto pick = std::min(static_cast<std::size_t>(rng.uniform() * static_cast<float>(candidates.size())),
                             candidates.size() - 1);
  const std::int32_t v = candidates[pick];
  // The particle came from a uniform point of the vacated cell to its own position within dt.
  const float sx = (static_cast<float>(v % w) + rng.uniform()) * res;
  const float sy = (static_cast<float>(v / w) + rng.uniform()) * res;
  vx = (x - sx) / dt;
  vy = (y - sy) / dt;
  return true;
}

std::size_t DynamicGridFilter::birthAndResample(std::size_t& born, float dt)
{
  // Both samplings are systematic, (u + k) * step for k = 0, 1, ... over the cumulative mass, and
  // run in blocks: each block sums its mass (in order), the exclusive prefix of these sums (in
  // block order) is where each block's cumulative mass starts, and an item whose cumulative mass
  // goes from C0 to C1 takes the samples count(C0) .. count(C1) - 1 (exact slots).
  // The last item of a block ends at the next block's start, so the blocks tile the samples.
  BlockRandom cycle_rng(config_.seed, cycle_, kPassCycle, 0);
  const float u_birth = cycle_rng.uniform();
  const float u_resample = cycle_rng.uniform();
  born = sampleBirths(u_birth, dt);
  return resample(u_resample, born);
}

std::size_t DynamicGridFilter::sampleBirths(float u_birth, float dt)
{
  // Eq. 10: B = ceil(birth_fraction * N) newborn particles spread over the cells measured
  // occupied (p_o > 0.5) by systematic sampling of their newborn mass.
  const auto gw = static_cast<std::size_t>(geometry_.width);
  const std::size_t row_blocks = blockCount(static_cast<std::size_t>(geometry_.height), kRowBlock);
  forRowBlocks(
      [&](std::size_t b, int r_begin, int r_end)
      {
        double sum = 0.0;
        for (std::size_t c = static_cast<std::size_t>(r_begin) * gw; c < static_cast<std::size_t>(r_end) * gw;
             ++c)
        {
          sum += newborn_[c];
        }
        block_sum_[b] = sum;
      });
  const double newborn_total = blockStarts(block_sum_, row_blocks, block_start_);
  const std::size_t capacity = birth_cell_.size();
  if (!(newborn_total > 1e-9))
  {
    return 0;
  }
  const double step = newborn_total / static_cast<double>(capacity);
  const SystematicSamples samples{u_birth, step, capacity};
  forRowBlocks([&](std::size_t b, int r_begin, int r_end)
               { birthInRowBlock(b, r_begin, r_end, samples, dt); });
  return samples.count(newborn_total);
}

void DynamicGridFilter::birthInRowBlock(std::size_t b, int r_begin, int r_end,
                                        const SystematicSamples& samples, float dt)
{
  const auto gw = static_cast<std::size_t>(geometry_.width);
  const std::size_t c_begin = static_cast<std::size_t>(r_begin) * gw;
  std::size_t c_last = static_cast<std::size_t>(r_end) * gw;  // the block's last cell with mass
  while (c_last > c_begin && newborn_[c_last - 1] <= 0.0F)
  {
    --c_last;
  }
  if (c_last == c_begin)
  {
    return;
  }
  --c_last;
  BlockRandom rng(config_.seed, cycle_, kPassBirth, b);
  std::vector<std::int32_t>& candidates = block_candidates_[b];
  const std::size_t block_end = samples.count(block_start_[b + 1]);
  double cumulative = block_start_[b];
  std::size_t first = samples.count(cumulative);
  for (std::size_t c = c_begin; c <= c_last; ++c)
  {
    if (newborn_[c] <= 0.0F)
    {
      continue;
    }
    cumulative += newborn_[c];
    const std::size_t end = c == c_last ? block_end : samples.advance(first, cumulative, block_end);
    if (end - first == 0)
    {
      continue;
    }
    bearParticles(c, first, end, dt, rng, candidates);
    first = end;
  }
}

void DynamicGridFilter::bearParticles(std::size_t c, std::size_t first, std::size_t end, float dt,
                                      BlockRandom& rng, std::vector<std::int32_t>& candidates)
{
  // Each newborn particle of cell c weighs newborn_c / n_c and is uniform in the cell.
  const float res = static_cast<float>(geometry_.resolution);
  const float sb = static_cast<float>(config_.birth_velocity_sigma);
  const auto fraction = static_cast<float>(config_.birth_motion_fraction);
  const auto gw = static_cast<std::size_t>(geometry_.width);
  const std::size_t count = end - first;
  const float w = newborn_[c] / static_cast<float>(count);
  const int row = static_cast<int>(c / gw);
  const int col = static_cast<int>(c % gw);
  const bool appearing = !vacated_.empty() && !previous_mask_[c];
  // Newborn mass by origin (shares of newborn_[c]): propagated (the source's velocity), vacated
  // (the velocity that left the cell), started (a motion-driven velocity); the rest takes the
  // cell's velocity estimate where it has persistent particles and motion evidence
  // (inherit_birth_velocity), a motion-driven velocity in an appearing cell
  // (birth_motion_fraction), else a random one, v ~ N(0, sigma_b^2 I).
  const float to_propagated = propagated_share_[c];
  const float to_vacated = to_propagated + vacated_share_[c];
  const float to_started = to_vacated + start_share_[c];
  const bool inherit =
      config_.inherit_birth_velocity && stat_w_[c] > 1e-6F && motion_evidence_[c] >= kEvidenceGate;
  for (std::size_t k = first; k < end; ++k)
  {
    birth_cell_[k] = static_cast<std::int32_t>(c);
    birth_x_[k] = (static_cast<float>(col) + rng.uniform()) * res;
    birth_y_[k] = (static_cast<float>(row) + rng.uniform()) * res;
    const float origin = to_started > 0.0F ? rng.uniform() : 1.0F;
    if (origin < to_propagated)
    {
      birth_vx_[k] = source_vx_[c] + std::sqrt(source_var_x_[c]) * normalSample(rng);
      birth_vy_[k] = source_vy_[c] + std::sqrt(source_var_y_[c]) * normalSample(rng);
    }
    else if (origin < to_vacated)
    {
      birth_vx_[k] = left_vx_[c] + std::sqrt(left_var_x_[c]) * normalSample(rng);
      birth_vy_[k] = left_vy_[c] + std::sqrt(left_var_y_[c]) * normalSample(rng);
    }
    else if (origin < to_started &&
             motionVelocity(c, birth_x_[k], birth_y_[k], dt, birth_vx_[k], birth_vy_[k], rng, candidates))
    {
    }
    else if (inherit)
    {
      birth_vx_[k] =
          cells_.vx[c] + std::sqrt(std::max(cells_.v_var_x[c], kInheritVarianceFloor)) * normalSample(rng);
      birth_vy_[k] =
          cells_.vy[c] + std::sqrt(std::max(cells_.v_var_y[c], kInheritVarianceFloor)) * normalSample(rng);
    }
    else if (!(appearing && rng.uniform() < fraction &&
               motionVelocity(c, birth_x_[k], birth_y_[k], dt, birth_vx_[k], birth_vy_[k], rng, candidates)))
    {
      birth_vx_[k] = sb * normalSample(rng);
      birth_vy_[k] = sb * normalSample(rng);
    }
    birth_w_[k] = w;
  }
}

std::size_t DynamicGridFilter::resample(float u_resample, std::size_t born)
{
  // Eq. 11: systematic resampling of the persistent and newborn particles to N particles of
  // equal weight W / N, W = their total weight (the dynamic mass carried stays the same). The
  // items: the particles, then the newborn ones, in blocks of kParticleBlock.
  ParticleArrays& p = particles_;
  const std::size_t n = p.size();
  const std::size_t particle_blocks = blockCount(n, kParticleBlock);
  const std::size_t item_blocks = particle_blocks + blockCount(born, kParticleBlock);
  parallel_.run(item_blocks,
                [&](std::size_t b)
                {
                  std::size_t begin = 0;
                  std::size_t end = 0;
                  itemRange(b, particle_blocks, n, born, begin, end);
                  const float* weight = b < particle_blocks ? p.weight.data() : birth_w_.data();
                  double sum = 0.0;
                  for (std::size_t i = begin; i < end; ++i)
                  {
                    if (weight[i] > 0.0F)
                    {
                      sum += weight[i];
                    }
                  }
                  block_sum_[b] = sum;
                });
  const double total = blockStarts(block_sum_, item_blocks, block_start_);
  if (total <= 1e-12)
  {
    std::fill(p.weight.begin(), p.weight.end(), 0.0F);
    std::fill(p.cell.begin(), p.cell.end(), -1);
    return 0;
  }
  const double step = total / static_cast<double>(n);
  const SystematicSamples samples{u_resample, step, n};
  const std::size_t in_use = samples.count(total);
  parallel_.run(item_blocks, [&](std::size_t b) { resampleBlock(b, particle_blocks, born, samples); });
  // Rounding at the very end: no particle left to copy.
  ParticleArrays& r = resampled_;
  std::fill(r.weight.begin() + static_cast<std::ptrdiff_t>(in_use), r.weight.end(), 0.0F);
  std::fill(r.cell.begin() + static_cast<std::ptrdiff_t>(in_use), r.cell.end(), -1);
  std::swap(particles_, resampled_);
  return in_use;
}

void DynamicGridFilter::resampleBlock(std::size_t b, std::size_t particle_blocks, std::size_t born,
                                      const SystematicSamples& samples)
{
  const ParticleArrays& p = particles_;
  ParticleArrays& r = resampled_;
  const auto w_out = static_cast<float>(samples.step);
  std::size_t begin = 0;
  std::size_t end = 0;
  itemRange(b, particle_blocks, p.size(), born, begin, end);
  const bool newborn = b >= particle_blocks;
  const float* x = newborn ? birth_x_.data() : p.x.data();
  const float* y = newborn ? birth_y_.data() : p.y.data();
  const float* vx = newborn ? birth_vx_.data() : p.vx.data();
  const float* vy = newborn ? birth_vy_.data() : p.vy.data();
  const float* weight = newborn ? birth_w_.data() : p.weight.data();
  const std::int32_t* cell = newborn ? birth_cell_.data() : p.cell.data();
  std::size_t last = end;  // the block's last item with weight
  while (last > begin && !(weight[last - 1] > 0.0F))
  {
    --last;
  }
  if (last == begin)
  {
    return;
  }
  --last;
  const std::size_t block_end = samples.count(block_start_[b + 1]);
  double cumulative = block_start_[b];
  std::size_t out = samples.count(cumulative);
  for (std::size_t i = begin; i <= last; ++i)
  {
    if (!(weight[i] > 0.0F))
    {
      continue;
    }
    cumulative += weight[i];
    const std::size_t out_end = i == last ? block_end : samples.advance(out, cumulative, block_end);
    for (; out < out_end; ++out)
    {
      r.x[out] = x[i];
      r.y[out] = y[i];
      r.vx[out] = vx[i];
      r.vy[out] = vy[i];
      r.weight[out] = w_out;
      r.cell[out] = cell[i];
    }
  }
}

void DynamicGridFilter::setClassification(const DynamicGridConfig& thresholds)
{
  DynamicGridConfig updated = config_;
  updated.dynamic_threshold = thresholds.dynamic_threshold;
  updated.min_dynamic_speed = thresholds.min_dynamic_speed;
  updated.mahalanobis_threshold = thresholds.mahalanobis_threshold;
  updated.occupied_threshold = thresholds.occupied_threshold;
  updated.validate();
  config_ = updated;
}

CellClass DynamicGridFilter::classify(std::size_t index) const
{
  const float ps = cells_.p_static[index];
  const float pd = cells_.p_dynamic[index];
  const float pe = cells_.p_free[index];
  const float pu = cells_.p_unknown[index];
  if (pd >= config_.dynamic_threshold)
  {
    const float vx = cells_.vx[index];
    const float vy = cells_.vy[index];
    const float speed2 = vx * vx + vy * vy;
    const float m2 =
        vx * vx / std::max(cells_.v_var_x[index], 1e-6F) + vy * vy / std::max(cells_.v_var_y[index], 1e-6F);
    if (speed2 >= config_.min_dynamic_speed * config_.min_dynamic_speed &&
        m2 >= config_.mahalanobis_threshold)
    {
      return CellClass::kDynamic;
    }
  }
  if (ps + pd >= config_.occupied_threshold)
  {
    return CellClass::kStatic;
  }
  if (pe > pu && pe > ps + pd)
  {
    return CellClass::kFree;
  }
  return CellClass::kUnknown;
}

}  // namespace grid_vision_fusion
