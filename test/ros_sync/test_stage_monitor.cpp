// StageMonitor: rates over the window, latency from the sensor stamp, drops by reason, and the
// stalls a nodelet warns about (an input silent while another arrives; inputs without output).
#include <gtest/gtest.h>

#include <string>
#include <utility>
#include <vector>

#include "grid_vision_fusion/ros_sync/stage_monitor.h"

namespace grid_vision_fusion
{
namespace
{
using Inputs = std::vector<std::pair<std::string, std::string>>;

TEST(StageMonitor, RatesAndLatencyOverTheWindow)
{
  StageMonitor monitor({{"grids", "/grid"}, {"camera_infos", "/camera_info"}}, 5.0);
  // 10 Hz of each input for 10 s; every other one an output for a sensor stamp 0.2 s earlier.
  for (int i = 0; i < 100; ++i)
  {
    const double t = 100.0 + 0.1 * i;
    monitor.input("grids", t);
    monitor.input("camera_infos", t);
    if (i % 2 == 0)
    {
      monitor.output(t, t - 0.2);
    }
  }
  const StageMonitor::Report report = monitor.report(110.0);
  EXPECT_NEAR(report.input_rate_hz.at("grids"), 10.0, 0.3);
  EXPECT_NEAR(report.input_rate_hz.at("camera_infos"), 10.0, 0.3);
  EXPECT_NEAR(report.output_rate_hz, 5.0, 0.3);
  EXPECT_NEAR(report.latency_median_s, 0.2, 1e-6);
  EXPECT_NEAR(report.latency_max_s, 0.2, 1e-6);
  EXPECT_EQ(report.outputs, 50U);
  EXPECT_TRUE(report.stalls.empty()) << report.stalls.front();
}

TEST(StageMonitor, DropsAreCountedByReasonWithTheLastDetail)
{
  StageMonitor monitor(Inputs{{"scans", "/points"}});
  monitor.drop("no tf", "odom <- 'velo' at t=1");
  monitor.drop("no tf", "odom <- 'velo' at t=2");
  monitor.drop("unusable cloud");
  StageMonitor::Report report = monitor.report(1.0);
  EXPECT_EQ(report.drops.at("no tf").first, 2U);
  EXPECT_EQ(report.drops.at("no tf").second, "odom <- 'velo' at t=2");
  EXPECT_EQ(report.drops.at("unusable cloud").first, 1U);
  EXPECT_EQ(report.new_drops, 3U);
  EXPECT_EQ(monitor.report(2.0).new_drops, 0U) << "counted since the previous report";
}

TEST(StageMonitor, AnInputSilentWhileAnotherArrivesIsAStall)
{
  StageMonitor monitor({{"grids", "/grid"}, {"camera_infos", "/kitti/camera_info"}});
  for (int i = 0; i <= 30; ++i)
  {
    monitor.input("grids", 10.0 + 0.1 * i);
  }
  StageMonitor::Report report = monitor.report(13.0);
  ASSERT_EQ(report.stalls.size(), 1U);
  EXPECT_EQ(report.stalls[0], "grids arrive on /grid but no camera_infos on /kitti/camera_info for 3.0 s");
  // Under a second of silence is not a stall yet.
  StageMonitor fresh({{"grids", "/grid"}, {"camera_infos", "/kitti/camera_info"}});
  fresh.input("grids", 10.0);
  EXPECT_TRUE(fresh.report(10.5).stalls.empty());
}

TEST(StageMonitor, InputsWithoutOutputAreAStallNamingTheCommonestDrop)
{
  StageMonitor monitor(Inputs{{"scans", "/points"}});
  for (int i = 0; i <= 20; ++i)
  {
    monitor.input("scans", 50.0 + 0.1 * i);
    monitor.drop("no tf", "odom <- 'velo_link'");
  }
  const StageMonitor::Report report = monitor.report(52.0);
  ASSERT_EQ(report.stalls.size(), 1U);
  EXPECT_EQ(report.stalls[0],
            "inputs arrive but nothing was published for 2.0 s (most drops: no tf: odom <- 'velo_link')");
  monitor.output(52.0, 51.9);
  EXPECT_TRUE(monitor.report(52.1).stalls.empty());
}

TEST(StageMonitor, TimeGoingBackwardsStartsAfresh)
{
  StageMonitor monitor(Inputs{{"images", "/image"}});
  for (int i = 0; i < 50; ++i)
  {
    monitor.input("images", 200.0 + 0.1 * i);
    monitor.output(200.0 + 0.1 * i, 200.0 + 0.1 * i);
  }
  // The bag plays again from its start: no stall, no negative latency.
  monitor.input("images", 100.0);
  monitor.output(100.05, 100.0);
  const StageMonitor::Report report = monitor.report(100.1);
  EXPECT_TRUE(report.stalls.empty());
  EXPECT_NEAR(report.latency_median_s, 0.05, 1e-9);
  EXPECT_EQ(report.outputs, 51U);
}

}  // namespace
}  // namespace grid_vision_fusion
