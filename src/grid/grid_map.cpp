#include "grid_vision_fusion/grid/grid_map.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>

namespace grid_vision_fusion
{
bool GridGeometry::cellOf(double x, double y, int& row, int& col) const
{
  const double fc = std::floor((x - originX()) / resolution);
  const double fr = std::floor((y - originY()) / resolution);
  if (!(fc >= 0.0 && fr >= 0.0 && fc < width && fr < height))
  {
    return false;
  }
  col = static_cast<int>(fc);
  row = static_cast<int>(fr);
  return true;
}

void CellStates::reset(std::size_t cells, float prior_velocity_variance)
{
  p_static.assign(cells, 0.0F);
  p_dynamic.assign(cells, 0.0F);
  p_free.assign(cells, 0.0F);
  p_unknown.assign(cells, 1.0F);
  vx.assign(cells, 0.0F);
  vy.assign(cells, 0.0F);
  v_var_x.assign(cells, prior_velocity_variance);
  v_var_y.assign(cells, prior_velocity_variance);
}

namespace
{
void shiftArray(std::vector<float>& a, int width, int height, std::int64_t d_col, std::int64_t d_row,
                float fill)
{
  if (std::llabs(d_col) >= width || std::llabs(d_row) >= height)
  {
    std::fill(a.begin(), a.end(), fill);
    return;
  }
  const int dc = static_cast<int>(d_col);
  const int dr = static_cast<int>(d_row);
  const auto w = static_cast<std::size_t>(width);
  // New row r takes old row r + dr; iterate so a row is never overwritten before it is read.
  const int r_begin = dr >= 0 ? 0 : height - 1;
  const int r_end = dr >= 0 ? height : -1;
  const int r_step = dr >= 0 ? 1 : -1;
  const int c_lo = std::max(0, -dc);             // first new column with an old source
  const int c_hi = std::min(width, width - dc);  // one past the last
  for (int r = r_begin; r != r_end; r += r_step)
  {
    float* dst = a.data() + static_cast<std::size_t>(r) * w;
    const int src_r = r + dr;
    if (src_r < 0 || src_r >= height)
    {
      std::fill(dst, dst + w, fill);
      continue;
    }
    const float* src = a.data() + static_cast<std::size_t>(src_r) * w;
    if (c_hi > c_lo)
    {
      std::memmove(dst + c_lo, src + c_lo + dc, static_cast<std::size_t>(c_hi - c_lo) * sizeof(float));
    }
    std::fill(dst, dst + c_lo, fill);
    std::fill(dst + c_hi, dst + w, fill);
  }
}
}  // namespace

void shiftCells(CellStates& states, int width, int height, std::int64_t d_col, std::int64_t d_row,
                float prior_velocity_variance)
{
  shiftCells(states, width, height, d_col, d_row, prior_velocity_variance, ParallelBlocks(1));
}

void shiftCells(CellStates& states, int width, int height, std::int64_t d_col, std::int64_t d_row,
                float prior_velocity_variance, const ParallelBlocks& parallel)
{
  if (d_col == 0 && d_row == 0)
  {
    return;
  }
  // One array per block.
  std::vector<float>* arrays[] = {&states.p_static, &states.p_dynamic, &states.p_free,  &states.p_unknown,
                                  &states.vx,       &states.vy,        &states.v_var_x, &states.v_var_y};
  const float fills[] = {
      0.0F, 0.0F, 0.0F, 1.0F, 0.0F, 0.0F, prior_velocity_variance, prior_velocity_variance};
  parallel.run(8, [&](std::size_t k) { shiftArray(*arrays[k], width, height, d_col, d_row, fills[k]); });
}

}  // namespace grid_vision_fusion
