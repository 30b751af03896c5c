// CMCDOT-style dynamic occupancy grid filter (a documented reconstruction,
// doc/grid_filter.md, whose equation numbers the comments below refer to),
// steps 4-7: the cell update (eq. 5-7), the velocities of the cells (eq. 8-9), and the
// classification for reporting.
#include "grid_vision_fusion/grid/dynamic_grid_filter.h"

#include <algorithm>
#include <array>
#include <cmath>

#include "dynamic_grid_steps.h"

namespace grid_vision_fusion
{
using dynamic_grid_detail::perInterval;
using dynamic_grid_detail::Row;
using dynamic_grid_detail::scaledRow;
using dynamic_grid_detail::velocitySignificance;

namespace
{
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
}  // namespace

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
