// Inverse sensor model on box-world scans: ground removal, free/occupied/unknown by ray
// casting, the occupied band, NaN handling, validation.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <limits>
#include <string>

#include "box_world_lidar.h"
#include "grid_vision_fusion/grid/inverse_sensor_model.h"

namespace grid_vision_fusion
{
namespace
{
using testing::Box;
using testing::BoxWorldLidar;
using testing::BoxWorldLidarConfig;
using testing::sensorPose;

// 60 m x 60 m grid of 0.2 m cells, x from -15 m, y from -30 m.
GridGeometry testGrid()
{
  GridGeometry g;
  g.width = 300;
  g.height = 300;
  g.resolution = 0.2;
  g.origin_col = -75;
  g.origin_row = -150;
  return g;
}

float at(const std::vector<float>& occupancy, const GridGeometry& g, double x, double y)
{
  int row = 0;
  int col = 0;
  EXPECT_TRUE(g.cellOf(x, y, row, col)) << x << "," << y;
  return occupancy[g.index(row, col)];
}

TEST(FastAtan2, MatchesStdAtan2)
{
  float max_error = 0.0F;
  for (int i = 0; i < 3600; ++i)
  {
    const double a = i * M_PI / 1800.0 - M_PI + 1e-4;
    for (double r : {0.01, 1.0, 100.0})
    {
      const auto x = static_cast<float>(r * std::cos(a));
      const auto y = static_cast<float>(r * std::sin(a));
      max_error = std::max(max_error, std::fabs(fastAtan2(y, x) - std::atan2(y, x)));
    }
  }
  EXPECT_LT(max_error, 2e-5F);
  EXPECT_NEAR(fastAtan2(0.0F, -1.0F), static_cast<float>(M_PI), 1e-6F);
  EXPECT_EQ(fastAtan2(0.0F, 0.0F), 0.0F);
}

// Cells seen free (p_o < 1/2) that have a cell holding obstacle points (p_o = p_occupied) in
// their 8-neighbourhood.
std::size_t freeNextToHits(const std::vector<float>& occ, const GridGeometry& g, float p_occ)
{
  std::size_t n = 0;
  for (int row = 1; row + 1 < g.height; ++row)
  {
    for (int col = 1; col + 1 < g.width; ++col)
    {
      if (occ[g.index(row, col)] >= 0.5F)
      {
        continue;
      }
      bool near = false;
      for (int dr = -1; dr <= 1; ++dr)
      {
        for (int dc = -1; dc <= 1; ++dc)
        {
          near = near || occ[g.index(row + dr, col + dc)] >= p_occ;
        }
      }
      n += near ? 1 : 0;
    }
  }
  return n;
}

TEST(InverseSensorModel, HitNeighboursAreNeverFree)
{
  // A wall along the road seen at a grazing angle: a polar sector's nearest hit can lie beyond
  // the part of the wall that crosses the sector, and without the rule cells of the wall next
  // to its hits are "seen free" (and flicker between hit and free from scan to scan, which the
  // filter would read as motion).
  const GridGeometry g = testGrid();
  BoxWorldLidarConfig lidar_config;
  lidar_config.range_noise_sigma = 0.02;
  BoxWorldLidar lidar(lidar_config);
  const auto pose = sensorPose(0.0, 0.0, 1.73);
  Box wall;
  wall.x = 25.0;
  wall.y = -3.05;
  wall.length = 30.0;
  wall.width = 0.3;
  wall.height = 2.0;
  const std::vector<float> xyz = lidar.scan(pose, {wall});
  InverseSensorModelConfig config;
  const auto p_occ = static_cast<float>(config.p_occupied);
  config.hit_neighbours_not_free = false;
  InverseSensorModel previous(config);
  std::vector<float> before;
  previous.compute(PointCloudView::packedXyz(xyz.data(), xyz.size() / 3), pose, g, before);
  EXPECT_GT(freeNextToHits(before, g, p_occ), 0U) << "the scene does not show the grazing-angle case";
  config.hit_neighbours_not_free = true;
  InverseSensorModel model(config);
  std::vector<float> after;
  model.compute(PointCloudView::packedXyz(xyz.data(), xyz.size() / 3), pose, g, after);
  EXPECT_EQ(freeNextToHits(after, g, p_occ), 0U);
  // Nothing else changes: the road between the sensor and the wall is still free.
  for (double x : {6.0, 12.0, 20.0})
  {
    EXPECT_LT(at(after, g, x, -1.0), 0.5F) << x;
    EXPECT_FLOAT_EQ(at(after, g, x, -1.0), at(before, g, x, -1.0)) << x;
  }
}

TEST(InverseSensorModel, FreeBeforeTheBoxOccupiedAtItUnknownBehind)
{
  const GridGeometry g = testGrid();
  BoxWorldLidar lidar;
  const auto pose = sensorPose(0.0, 0.0, 1.73);
  Box box;
  box.x = 15.0;  // front face at x = 14
  box.length = 2.0;
  box.width = 4.0;
  const std::vector<float> xyz = lidar.scan(pose, {box});
  const InverseSensorModelConfig config;
  const auto p_occ = static_cast<float>(config.p_occupied);
  const auto p_free = static_cast<float>(config.p_free);
  InverseSensorModel model(config);
  std::vector<float> occ;
  const InverseSensorModelStats stats =
      model.compute(PointCloudView::packedXyz(xyz.data(), xyz.size() / 3), pose, g, occ);
  ASSERT_EQ(occ.size(), g.cellCount());
  EXPECT_EQ(stats.invalid_points, 0U);
  EXPECT_GT(stats.obstacle_points, 100U);
  EXPECT_GT(stats.ground_points, 10000U);

  EXPECT_FLOAT_EQ(at(occ, g, 10.0, 0.1), p_free);  // free in front
  EXPECT_FLOAT_EQ(at(occ, g, 14.05, 0.1), p_occ);  // holds obstacle points
  EXPECT_FLOAT_EQ(at(occ, g, 14.05, -1.9), p_occ);
  EXPECT_FLOAT_EQ(at(occ, g, 20.0, 0.1), 0.5F);  // in its shadow
  EXPECT_FLOAT_EQ(at(occ, g, 40.0, 0.1), 0.5F);
  EXPECT_FLOAT_EQ(at(occ, g, 10.0, 10.1), p_free);  // free beside it
  EXPECT_FLOAT_EQ(at(occ, g, -10.0, 0.1), p_free);  // free behind the vehicle
  EXPECT_FLOAT_EQ(at(occ, g, 1.0, 0.1), 0.5F);      // inside min_range: not observed
  // Occupied band: the nearest hit of the sector [0, 0.5) deg is the face point at (14, 0);
  // cell centre (13.9, 0.1) lies d = hypot(13.9, 0.1) - 14 = -0.0996 m before it:
  // p = p_free + (p_occ - p_free) exp(-d^2 / (2 sigma^2)) = 0.845.
  const double d = std::hypot(13.9, 0.1) - 14.0;
  EXPECT_NEAR(at(occ, g, 13.9, 0.1),
              p_free + (p_occ - p_free) * std::exp(-d * d / (2.0 * config.range_sigma * config.range_sigma)),
              0.005);
  // 1 m behind the hit (5 sigma): no information.
  EXPECT_FLOAT_EQ(at(occ, g, 15.1, 0.1), 0.5F);
  // Cells holding obstacle points are occupied even at long range.
  Box far_box;
  far_box.x = 42.0;
  far_box.y = 20.0;
  const std::vector<float> far_xyz = lidar.scan(pose, {far_box});
  model.compute(PointCloudView::packedXyz(far_xyz.data(), far_xyz.size() / 3), pose, g, occ);
  EXPECT_FLOAT_EQ(at(occ, g, 40.05, 19.1), p_occ);
  // The sensor's ground estimate below a box is the ground, not the box.
  EXPECT_NEAR(model.groundHeight(0.0, 14.5), -1.73, 0.05);
}

TEST(InverseSensorModel, SlopedGroundIsNotAnObstacle)
{
  const GridGeometry g = testGrid();
  BoxWorldLidarConfig lidar_config;
  lidar_config.ground_slope_x = std::tan(4.0 * M_PI / 180.0);  // 4 degrees uphill along +x
  lidar_config.ground_height = 0.0;
  BoxWorldLidar lidar(lidar_config);
  const auto pose = sensorPose(0.0, 0.0, 1.73);
  const InverseSensorModelConfig config;
  const auto p_occ = static_cast<float>(config.p_occupied);
  const auto p_free = static_cast<float>(config.p_free);
  InverseSensorModel model{config};
  std::vector<float> occ;
  const std::vector<float> xyz = lidar.scan(pose, {});
  const InverseSensorModelStats stats =
      model.compute(PointCloudView::packedXyz(xyz.data(), xyz.size() / 3), pose, g, occ);
  // A fixed z threshold of 0.3 m above the sensor's ground would call the slope occupied from
  // about 4.3 m on (0.3 / tan 4 deg); the per-sector ground estimate follows it.
  EXPECT_EQ(stats.obstacle_points, 0U);
  EXPECT_EQ(stats.occupied_cells, 0U);
  EXPECT_FLOAT_EQ(at(occ, g, 30.0, 0.1), p_free);
  EXPECT_NEAR(model.groundHeight(0.0, 30.0), -1.73 + 30.0 * lidar_config.ground_slope_x, 0.1);

  Box box;
  box.x = 20.0;
  const std::vector<float> with_box = lidar.scan(pose, {box});
  model.compute(PointCloudView::packedXyz(with_box.data(), with_box.size() / 3), pose, g, occ);
  EXPECT_FLOAT_EQ(at(occ, g, 18.05, 0.1), p_occ);
  EXPECT_FLOAT_EQ(at(occ, g, 15.0, 0.1), p_free);
}

TEST(InverseSensorModel, NanPointsAreDroppedAndCounted)
{
  const GridGeometry g = testGrid();
  BoxWorldLidar lidar;
  const auto pose = sensorPose(0.0, 0.0, 1.73);
  std::vector<float> xyz = lidar.scan(pose, {});
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const float inf = std::numeric_limits<float>::infinity();
  xyz.insert(xyz.end(), {nan, 0.0F, 0.0F, 1.0F, inf, 0.0F, 5.0F, 0.0F, -inf});
  InverseSensorModel model{InverseSensorModelConfig()};
  std::vector<float> occ;
  const InverseSensorModelStats stats =
      model.compute(PointCloudView::packedXyz(xyz.data(), xyz.size() / 3), pose, g, occ);
  EXPECT_EQ(stats.invalid_points, 3U);
  EXPECT_EQ(stats.points, xyz.size() / 3);
  EXPECT_EQ(stats.occupied_cells, 0U);
  for (float p : occ)
  {
    ASSERT_TRUE(p >= 0.0F && p <= 1.0F);
  }
}

TEST(InverseSensorModel, StridedViewOfAForeignBuffer)
{
  // Points of 16 bytes (x, y, z, intensity) in two rows padded to 40 bytes, as a PointCloud2.
  std::vector<std::uint8_t> buffer(80, 0);
  const float p0[4] = {10.0F, 0.0F, -1.73F, 7.0F};
  const float p1[4] = {12.0F, 0.0F, -1.0F, 7.0F};  // 0.73 m above the ground: obstacle
  std::memcpy(buffer.data(), p0, sizeof(p0));
  std::memcpy(buffer.data() + 40, p1, sizeof(p1));
  PointCloudView view;
  view.data = buffer.data();
  view.width = 1;
  view.height = 2;
  view.point_step = 16;
  view.row_step = 40;
  InverseSensorModel model{InverseSensorModelConfig()};
  const auto p_occ = static_cast<float>(model.config().p_occupied);
  std::vector<float> occ;
  const GridGeometry g = testGrid();
  const InverseSensorModelStats stats = model.compute(view, sensorPose(0.0, 0.0, 1.73), g, occ);
  EXPECT_EQ(stats.ground_points, 1U);
  EXPECT_EQ(stats.obstacle_points, 1U);
  EXPECT_FLOAT_EQ(at(occ, g, 12.1, 0.1), p_occ);
}

TEST(InverseSensorModelConfig, ValidateNamesTheField)
{
  InverseSensorModelConfig config;
  EXPECT_NO_THROW(config.validate());
  config.p_free = 0.7;
  try
  {
    config.validate();
    FAIL() << "p_free 0.7 accepted";
  }
  catch (const std::invalid_argument& e)
  {
    EXPECT_NE(std::string(e.what()).find("p_free"), std::string::npos);
  }
  config = InverseSensorModelConfig();
  config.max_range = 1.0;
  EXPECT_THROW(config.validate(), std::invalid_argument);
  config = InverseSensorModelConfig();
  config.max_obstacle_height = 0.1;
  EXPECT_THROW(config.validate(), std::invalid_argument);
}

}  // namespace
}  // namespace grid_vision_fusion
