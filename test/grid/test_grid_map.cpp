// GridGeometry and the integer-cell shift of the cell states.
#include <gtest/gtest.h>

#include <cstdint>
#include <set>
#include <vector>

#include "grid_vision_fusion/grid/grid_array.h"
#include "grid_vision_fusion/grid/grid_map.h"

namespace grid_vision_fusion
{
namespace
{
TEST(GridGeometry, CellOfUsesTheLatticeOrigin)
{
  GridGeometry g;
  g.width = 10;
  g.height = 5;
  g.resolution = 0.5;
  g.origin_col = -4;  // x from -2 m
  g.origin_row = 2;   // y from 1 m
  int row = -1;
  int col = -1;
  ASSERT_TRUE(g.cellOf(-2.0, 1.0, row, col));
  EXPECT_EQ(row, 0);
  EXPECT_EQ(col, 0);
  ASSERT_TRUE(g.cellOf(2.99, 3.49, row, col));
  EXPECT_EQ(row, 4);
  EXPECT_EQ(col, 9);
  EXPECT_FALSE(g.cellOf(3.0, 2.0, row, col));
  EXPECT_FALSE(g.cellOf(0.0, 0.99, row, col));
  EXPECT_DOUBLE_EQ(g.cellCenterX(0), -1.75);
  EXPECT_DOUBLE_EQ(g.cellCenterY(4), 3.25);
}

TEST(GridArray, LargeArraysStartAtDifferentCacheLinesOfAPage)
{
  // 16 arrays of a 300 x 300 grid, allocated one after the other as the filter does: each starts
  // on a cache line, no two at the same offset within a page (std::vector's would all come from
  // mmap at the same offset).
  std::vector<GridArray<float>> arrays;
  std::set<std::uintptr_t> page_offsets;
  for (int k = 0; k < 16; ++k)
  {
    arrays.emplace_back(300 * 300, static_cast<float>(k));
    const auto address = reinterpret_cast<std::uintptr_t>(arrays.back().data());
    EXPECT_EQ(address % 64, 0U) << "array " << k;
    page_offsets.insert(address % 4096);
  }
  EXPECT_EQ(page_offsets.size(), arrays.size());
  // The storage behaves as a vector's: contents kept when it grows, copies equal, freed in any
  // order (the sanitizer build checks the frees).
  GridArray<float> grown = arrays[3];
  grown.resize(400 * 400, -1.0F);
  EXPECT_EQ(grown[300 * 300 - 1], 3.0F);
  EXPECT_EQ(grown[300 * 300], -1.0F);
  EXPECT_EQ(GridArray<float>(arrays[5]), arrays[5]);
  arrays.erase(arrays.begin() + 2);
  arrays.clear();
}

TEST(ShiftCells, MovesContentByWholeCellsAndFillsUnknown)
{
  const int w = 4;
  const int h = 3;
  CellStates s;
  s.reset(w * h, 9.0F);
  for (int i = 0; i < w * h; ++i)
  {
    s.p_static[i] = static_cast<float>(i) / 100.0F;
    s.p_unknown[i] = 1.0F - s.p_static[i];
    s.vx[i] = static_cast<float>(i);
  }
  // The grid moves by +1 column and -1 row: new (r, c) = old (r - 1, c + 1).
  shiftCells(s, w, h, 1, -1, 9.0F);
  for (int r = 0; r < h; ++r)
  {
    for (int c = 0; c < w; ++c)
    {
      const int i = r * w + c;
      const int old_r = r - 1;
      const int old_c = c + 1;
      if (old_r >= 0 && old_c < w)
      {
        EXPECT_FLOAT_EQ(s.vx[i], static_cast<float>(old_r * w + old_c)) << r << "," << c;
        EXPECT_FLOAT_EQ(s.p_static[i] + s.p_unknown[i], 1.0F);
      }
      else
      {
        EXPECT_FLOAT_EQ(s.p_unknown[i], 1.0F) << r << "," << c;
        EXPECT_FLOAT_EQ(s.p_static[i], 0.0F);
        EXPECT_FLOAT_EQ(s.vx[i], 0.0F);
        EXPECT_FLOAT_EQ(s.v_var_x[i], 9.0F);
      }
    }
  }
  // The reverse shift brings the surviving cells back.
  shiftCells(s, w, h, -1, 1, 9.0F);
  EXPECT_FLOAT_EQ(s.vx[0 * w + 1], 1.0F);
  EXPECT_FLOAT_EQ(s.vx[1 * w + 3], 7.0F);
  EXPECT_FLOAT_EQ(s.vx[1 * w + 0], 0.0F);  // column 0 was shifted out, came back unknown
  EXPECT_FLOAT_EQ(s.p_unknown[1 * w + 0], 1.0F);
  EXPECT_FLOAT_EQ(s.p_unknown[2 * w + 1], 1.0F);  // so was row 2
  // A shift larger than the grid clears everything.
  shiftCells(s, w, h, 0, 7, 9.0F);
  for (int i = 0; i < w * h; ++i)
  {
    EXPECT_FLOAT_EQ(s.p_unknown[i], 1.0F);
  }
}

}  // namespace
}  // namespace grid_vision_fusion
