// The dynamic grid on several threads: for a seed and an input sequence, the cell states, the
// particles, the measured occupancy, the motion evidence and the cycle counters are bit-identical
// whatever the thread count (doc/grid_filter.md, "Determinism").
#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <cmath>
#include <cstring>
#include <string>
#include <vector>

#include "box_world_lidar.h"
#include "grid_vision_fusion/grid/dynamic_grid_filter.h"
#include "grid_vision_fusion/grid/parallel_blocks.h"

namespace grid_vision_fusion
{
namespace
{
using testing::Box;
using testing::BoxWorldLidar;
using testing::sensorPose;

constexpr double kSensorHeight = 1.73;
constexpr double kPeriod = 0.1;

// Bit-for-bit equality (unlike ==, tells -0 from +0 and compares NaN payloads).
template <typename Vector>
bool sameBits(const Vector& a, const Vector& b)
{
  return a.size() == b.size() &&
         (a.empty() || std::memcmp(a.data(), b.data(), a.size() * sizeof(typename Vector::value_type)) == 0);
}

// Index of the first element whose bits differ (for the failure message), or the size.
template <typename Vector>
std::size_t firstDifference(const Vector& a, const Vector& b)
{
  for (std::size_t i = 0; i < std::min(a.size(), b.size()); ++i)
  {
    if (std::memcmp(&a[i], &b[i], sizeof(a[i])) != 0)
    {
      return i;
    }
  }
  return std::min(a.size(), b.size());
}

#define EXPECT_SAME_BITS(a, b, what) \
  EXPECT_TRUE(sameBits(a, b)) << what << ": first difference at index " << firstDifference(a, b)

struct SceneRun
{
  std::vector<DynamicGridCycle> cycles;
  std::vector<CellStates> cells;
  std::vector<ParticleArrays> particles;
  std::vector<std::vector<float>> occupancy;
  std::vector<GridArray<float>> evidence;
};

// A scene with everything the filter does: the ego driving along +x (grid shifts), parked boxes,
// a box driving ahead, one oncoming and one crossing (motion evidence, motion-driven and inherited
// birth, propagation), over `scans` scans, with a time gap (reset) before the last two.
SceneRun runScene(int threads, int scans)
{
  DynamicGridConfig config;
  config.particle_count = 1 << 16;  // 16 particle blocks
  config.birth_fraction = 0.2;      // 4 blocks of newborn particles
  config.threads = threads;
  DynamicGridFilter filter(config);
  testing::BoxWorldLidarConfig lidar_config;
  lidar_config.range_noise_sigma = 0.02;
  BoxWorldLidar lidar(lidar_config);
  SceneRun run;
  double gap = 0.0;
  for (int k = 0; k < scans; ++k)
  {
    const double t = k * kPeriod;
    const double ego_x = 8.0 * t;
    std::vector<Box> boxes;
    for (int parked = 0; parked < 6; ++parked)
    {
      Box box;
      box.x = 6.0 + 7.0 * parked;
      box.y = parked % 2 == 0 ? 5.0 : -5.0;
      boxes.push_back(box);
    }
    Box ahead;
    ahead.x = 14.0 + 6.0 * t;
    ahead.y = 1.5;
    Box oncoming;
    oncoming.x = 40.0 - 9.0 * t;
    oncoming.y = -2.0;
    Box crossing;
    crossing.x = 24.0;
    crossing.y = -12.0 + 5.0 * t;
    crossing.yaw = M_PI / 2.0;
    boxes.insert(boxes.end(), {ahead, oncoming, crossing});
    const auto pose = sensorPose(ego_x, 0.0, kSensorHeight, 0.02 * t);
    const std::vector<float> xyz = lidar.scan(pose, boxes);
    if (k == scans - 2)
    {
      gap = 2.0 * config.max_time_gap;
    }
    run.cycles.push_back(filter.update(PointCloudView::packedXyz(xyz.data(), xyz.size() / 3), pose, t + gap));
    run.cells.push_back(filter.cells());
    run.particles.push_back(filter.particles());
    run.occupancy.push_back(filter.measuredOccupancy());
    run.evidence.push_back(filter.motionEvidence());
  }
  return run;
}

void expectIdentical(const SceneRun& a, const SceneRun& b, const std::string& label)
{
  ASSERT_EQ(a.cycles.size(), b.cycles.size());
  for (std::size_t k = 0; k < a.cycles.size(); ++k)
  {
    const std::string at = label + ", scan " + std::to_string(k);
    const DynamicGridCycle& ca = a.cycles[k];
    const DynamicGridCycle& cb = b.cycles[k];
    EXPECT_EQ(ca.reset, cb.reset) << at;
    EXPECT_EQ(ca.shift_cols, cb.shift_cols) << at;
    EXPECT_EQ(ca.particles_in_use, cb.particles_in_use) << at;
    EXPECT_EQ(ca.particles_born, cb.particles_born) << at;
    EXPECT_EQ(ca.sensor.obstacle_points, cb.sensor.obstacle_points) << at;
    EXPECT_EQ(ca.sensor.ground_points, cb.sensor.ground_points) << at;
    EXPECT_EQ(ca.sensor.overhang_points, cb.sensor.overhang_points) << at;
    EXPECT_EQ(ca.sensor.out_of_range, cb.sensor.out_of_range) << at;
    EXPECT_EQ(ca.sensor.occupied_cells, cb.sensor.occupied_cells) << at;
    EXPECT_SAME_BITS(a.occupancy[k], b.occupancy[k], at + ", p_o");
    EXPECT_SAME_BITS(a.evidence[k], b.evidence[k], at + ", motion evidence");
    const CellStates& sa = a.cells[k];
    const CellStates& sb = b.cells[k];
    EXPECT_SAME_BITS(sa.p_static, sb.p_static, at + ", P(S)");
    EXPECT_SAME_BITS(sa.p_dynamic, sb.p_dynamic, at + ", P(D)");
    EXPECT_SAME_BITS(sa.p_free, sb.p_free, at + ", P(E)");
    EXPECT_SAME_BITS(sa.p_unknown, sb.p_unknown, at + ", P(U)");
    EXPECT_SAME_BITS(sa.vx, sb.vx, at + ", vx");
    EXPECT_SAME_BITS(sa.vy, sb.vy, at + ", vy");
    EXPECT_SAME_BITS(sa.v_var_x, sb.v_var_x, at + ", var vx");
    EXPECT_SAME_BITS(sa.v_var_y, sb.v_var_y, at + ", var vy");
    const ParticleArrays& pa = a.particles[k];
    const ParticleArrays& pb = b.particles[k];
    EXPECT_SAME_BITS(pa.x, pb.x, at + ", particle x");
    EXPECT_SAME_BITS(pa.y, pb.y, at + ", particle y");
    EXPECT_SAME_BITS(pa.vx, pb.vx, at + ", particle vx");
    EXPECT_SAME_BITS(pa.vy, pb.vy, at + ", particle vy");
    EXPECT_SAME_BITS(pa.weight, pb.weight, at + ", particle weight");
    EXPECT_SAME_BITS(pa.cell, pb.cell, at + ", particle cell");
  }
}

TEST(GridThreads, OutputBitIdenticalForOneTwoAndFourThreads)
{
  // Let oneTBB run 4 threads even on a machine with fewer cores (otherwise the 4-thread arena
  // would get as many workers as there are cores).
  const tbb::global_control allow(tbb::global_control::max_allowed_parallelism, 4);
  constexpr int kScans = 12;
  const SceneRun one = runScene(1, kScans);
  // The scene exercises the filter: moving cells, newborn particles, a reset.
  std::size_t dynamic = 0;
  const CellStates& last = one.cells[kScans - 3];  // the last scan before the reset
  for (std::size_t i = 0; i < last.size(); ++i)
  {
    dynamic += last.p_dynamic[i] > 0.5F && std::hypot(last.vx[i], last.vy[i]) > 2.0F ? 1 : 0;
  }
  EXPECT_GT(dynamic, 10U) << "the scene should have moving cells";
  EXPECT_GT(one.cycles[kScans - 3].particles_born, 4096U) << "several blocks of newborn particles";
  EXPECT_EQ(one.cycles[kScans - 3].particles_in_use, std::size_t{1} << 16);
  EXPECT_TRUE(one.cycles[kScans - 2].reset);
  EXPECT_NE(one.cycles[kScans - 3].shift_cols, 0) << "the ego should move the grid";
  for (const int threads : {2, 4})
  {
    expectIdentical(one, runScene(threads, kScans), std::to_string(threads) + " threads vs 1");
  }
}

TEST(GridThreads, SensorModelBitIdenticalOnThreads)
{
  BoxWorldLidar lidar;
  Box box;
  box.x = 10.0;
  const auto pose = sensorPose(0.0, 0.0, kSensorHeight, 0.3);
  const std::vector<float> xyz = lidar.scan(pose, {box, Box{20.0, -6.0, 5.0, 2.0, 3.0, 0.5}});
  const PointCloudView cloud = PointCloudView::packedXyz(xyz.data(), xyz.size() / 3);
  GridGeometry grid;
  grid.width = 300;
  grid.height = 260;
  grid.resolution = 0.2;
  grid.origin_col = -50;
  grid.origin_row = -130;
  InverseSensorModel serial_model{InverseSensorModelConfig()};
  std::vector<float> serial;
  const InverseSensorModelStats serial_stats = serial_model.compute(cloud, pose, grid, serial);
  ASSERT_GT(serial_stats.obstacle_points, 100U);
  for (const int threads : {1, 2, 3})
  {
    InverseSensorModel model{InverseSensorModelConfig()};
    std::vector<float> occupancy;
    const InverseSensorModelStats stats =
        model.compute(cloud, pose, grid, occupancy, ParallelBlocks(threads));
    EXPECT_SAME_BITS(serial, occupancy, std::to_string(threads) + " threads");
    EXPECT_EQ(stats.obstacle_points, serial_stats.obstacle_points);
    EXPECT_EQ(stats.ground_points, serial_stats.ground_points);
    EXPECT_EQ(stats.occupied_cells, serial_stats.occupied_cells);
    EXPECT_EQ(model.groundHeight(0.3, 10.0), serial_model.groundHeight(0.3, 10.0));
  }
}

TEST(GridThreads, ThreadCount)
{
  EXPECT_EQ(ParallelBlocks(1).threads(), 1);
  EXPECT_EQ(ParallelBlocks(3).threads(), 3);
  EXPECT_GE(ParallelBlocks(0).threads(), 1);  // all cores
  DynamicGridConfig config;
  config.threads = -1;
  EXPECT_THROW(config.validate(), std::invalid_argument);
  config.threads = 0;
  EXPECT_NO_THROW(config.validate());
}

TEST(GridThreads, RandomStreamsDependOnSeedCycleAndBlock)
{
  const std::uint64_t base = BlockRandom(42, 3, 2, 5).next();
  EXPECT_EQ(BlockRandom(42, 3, 2, 5).next(), base);
  EXPECT_NE(BlockRandom(43, 3, 2, 5).next(), base);
  EXPECT_NE(BlockRandom(42, 4, 2, 5).next(), base);
  EXPECT_NE(BlockRandom(42, 3, 3, 5).next(), base);
  EXPECT_NE(BlockRandom(42, 3, 2, 6).next(), base);
  // Roughly uniform: the mean of 10^5 draws within 0.005 of 1/2 (about 5 standard deviations).
  BlockRandom rng(1, 0, 0, 0);
  double sum = 0.0;
  for (int i = 0; i < 100000; ++i)
  {
    const float u = rng.uniform();
    ASSERT_GE(u, 0.0F);
    ASSERT_LT(u, 1.0F);
    sum += u;
  }
  EXPECT_NEAR(sum / 100000.0, 0.5, 0.005);
}

}  // namespace
}  // namespace grid_vision_fusion
