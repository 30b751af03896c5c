// CMCDOT-style dynamic occupancy grid filter (a documented reconstruction,
// doc/grid_filter.md, whose equation numbers the comments below refer to):
// the particles: prediction (step 3, eq. 3-4), birth (step 8, eq. 10) and resampling (step 9,
// eq. 11), and the normal samples they draw.
#include "grid_vision_fusion/grid/dynamic_grid_filter.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include "dynamic_grid_steps.h"
#include "grid_vision_fusion/normal_quantile.h"

namespace grid_vision_fusion
{
using dynamic_grid_detail::kEvidenceGate;
using dynamic_grid_detail::kParticleBlock;
using dynamic_grid_detail::kRowBlock;
using dynamic_grid_detail::normalTable;

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
constexpr float kInheritVarianceFloor = 0.25F;  // [m^2/s^2] floor of an inherited velocity variance
// Passes that draw random numbers: part of the seed of each block's stream.
enum Pass : std::uint32_t
{
  kPassCycle = 1,    // the offsets of the two systematic samplings
  kPassPredict = 2,  // process noise
  kPassBirth = 3,    // newborn particles
};

inline float normalSample(BlockRandom& rng)
{
  return normalTable()[rng.bits16()];
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

namespace dynamic_grid_detail
{
// Standard normal quantiles at the centres of 2^16 equal-probability slices: a 16-bit random
// index gives a normal sample (tails cut at +-4.3 sigma), a deterministic and fast sampler.
const std::vector<float>& normalTable()
{
  static const std::vector<float> table = []
  {
    std::vector<float> t(kNormalTableSize);
    for (std::size_t i = 0; i < kNormalTableSize; ++i)
    {
      t[i] = static_cast<float>(normalQuantile((static_cast<double>(i) + 0.5) / kNormalTableSize));
    }
    return t;
  }();
  return table;
}
}  // namespace dynamic_grid_detail

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

}  // namespace grid_vision_fusion
