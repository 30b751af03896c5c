// CMCDOT-style dynamic occupancy grid filter (a documented reconstruction,
// doc/grid_filter.md, whose equation numbers the comments below refer to):
// the motion evidence (vacated and appeared cells, the scan memory), the rigid-object prior
// (propagateMotion) and the velocities of motion-driven birth (motionVelocity).
#include "grid_vision_fusion/grid/dynamic_grid_filter.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include "dynamic_grid_steps.h"

namespace grid_vision_fusion
{
using dynamic_grid_detail::kBucket;
using dynamic_grid_detail::kEvidenceGate;
using dynamic_grid_detail::perInterval;
using dynamic_grid_detail::velocitySignificance;

namespace
{
// Motion evidence (doc/grid_filter.md, "Motion evidence").
constexpr float kClearlyFree = 0.25F;       // p_o at or below which a cell is seen clearly free
constexpr float kBelievedOccupied = 0.6F;   // P(S) + P(D) of a cell believed occupied
constexpr float kBelievedFree = 0.6F;       // P(E) of a cell believed free
constexpr float kSignificantMotion = 9.0F;  // m^2 of a propagation source (3 standard deviations)
}  // namespace

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

}  // namespace grid_vision_fusion
