// GridForImage: which grid a camera_info is projected with, and when it waits for it.
#include <gtest/gtest.h>

#include <sensor_msgs/CameraInfo.h>
#include <boost/make_shared.hpp>

#include <cmath>
#include <utility>
#include <vector>

#include "grid_vision_fusion/DynamicGrid.h"
#include "grid_vision_fusion/ros_sync/grid_for_image.h"

namespace grid_vision_fusion
{
namespace
{
using Pairing = GridForImage<DynamicGrid, sensor_msgs::CameraInfo>;

const ros::Time kT0(1317042000, 0);

ros::Time at(double s)
{
  return kT0 + ros::Duration(s);
}

DynamicGrid::ConstPtr grid(double s)
{
  auto g = boost::make_shared<DynamicGrid>();
  g->header.stamp = at(s);
  return g;
}

sensor_msgs::CameraInfo::ConstPtr info(double s)
{
  auto i = boost::make_shared<sensor_msgs::CameraInfo>();
  i->header.stamp = at(s);
  return i;
}

/// Seconds after kT0, to 0.1 ms (so that they compare equal to the literals).
double since(const ros::Time& t)
{
  return std::round((t - kT0).toSec() * 1e4) / 1e4;
}

/// The stamps (s after kT0) of the pairs' camera_infos and grids; −1 for no grid.
std::vector<std::pair<double, double>> stamps(const std::vector<Pairing::Pair>& pairs)
{
  std::vector<std::pair<double, double>> out;
  for (const Pairing::Pair& p : pairs)
  {
    out.emplace_back(since(p.info->header.stamp), p.grid ? since(p.grid->header.stamp) : -1.0);
  }
  return out;
}

using Stamps = std::vector<std::pair<double, double>>;

TEST(GridForImage, ACameraInfoBeforeTheGridOfItsSweepWaitsForIt)
{
  Pairing pairing(0.05);
  EXPECT_TRUE(pairing.addGrid(grid(0.0)).empty());
  // The image of the next sweep arrives while its grid is being computed.
  EXPECT_TRUE(pairing.addInfo(info(0.1)).empty());
  EXPECT_EQ(pairing.waiting(), 1U);
  EXPECT_EQ(stamps(pairing.addGrid(grid(0.1))), (Stamps{{0.1, 0.1}}));
  EXPECT_EQ(pairing.waiting(), 0U);
}

TEST(GridForImage, KittiStampsTheImageTenMillisecondsAfterTheCloud)
{
  Pairing pairing(0.05);
  pairing.addGrid(grid(0.0));
  EXPECT_TRUE(pairing.addInfo(info(0.1104)).empty());
  EXPECT_EQ(stamps(pairing.addGrid(grid(0.1))), (Stamps{{0.1104, 0.1}}));
  // A grid already there, within the tolerance before the image: no waiting.
  pairing.addGrid(grid(0.2));
  EXPECT_EQ(stamps(pairing.addInfo(info(0.2104))), (Stamps{{0.2104, 0.2}}));
}

TEST(GridForImage, TheNewestGridAtOrBeforeTheImageIsChosen)
{
  Pairing pairing(0.05);
  pairing.addGrid(grid(0.0));
  pairing.addGrid(grid(0.1));
  pairing.addGrid(grid(0.2));
  // A camera_info that waited for its tf, arriving after the next grid: its own sweep's grid.
  EXPECT_EQ(stamps(pairing.addInfo(info(0.1))), (Stamps{{0.1, 0.1}}));
  EXPECT_EQ(stamps(pairing.addInfo(info(0.15))), (Stamps{{0.15, 0.1}}));
  // Older than every grid kept: the oldest, the nearest after it (the projection's
  // max_grid_age decides whether it is near enough).
  EXPECT_EQ(stamps(pairing.addInfo(info(-0.5))), (Stamps{{-0.5, 0.0}}));
}

TEST(GridForImage, TheFirstCameraInfoWaitsForTheFirstGrid)
{
  Pairing pairing(0.05);
  EXPECT_TRUE(pairing.addInfo(info(0.0)).empty());
  EXPECT_EQ(stamps(pairing.addGrid(grid(0.0))), (Stamps{{0.0, 0.0}}));
}

TEST(GridForImage, TheNextCameraInfoEndsTheWait)
{
  Pairing pairing(0.05);
  pairing.addGrid(grid(0.0));
  EXPECT_TRUE(pairing.addInfo(info(0.1)).empty());
  // The lidar is a frame late: the waiting camera_info takes the grid that is there, the new one
  // waits in its turn.
  EXPECT_EQ(stamps(pairing.addInfo(info(0.2))), (Stamps{{0.1, 0.0}}));
  EXPECT_EQ(pairing.waiting(), 1U);
  // A late grid of an earlier sweep does not complete it.
  EXPECT_TRUE(pairing.addGrid(grid(0.1)).empty());
  EXPECT_EQ(stamps(pairing.addGrid(grid(0.2))), (Stamps{{0.2, 0.2}}));
}

TEST(GridForImage, CameraInfosWaitForTheFirstGridEvenPastTheNextCameraInfo)
{
  // The first grid is the slowest (the filter starts, the first scan's tf comes late): the first
  // camera_infos wait for it instead of being given up with nothing when the next one arrives.
  Pairing pairing(0.05);
  EXPECT_TRUE(pairing.addInfo(info(0.0)).empty());
  EXPECT_TRUE(pairing.addInfo(info(0.1)).empty());
  EXPECT_EQ(stamps(pairing.addGrid(grid(0.0))), (Stamps{{0.0, 0.0}}));
  EXPECT_EQ(pairing.waiting(), 1U);  // 0.1 waits for its own sweep's grid, as usual
  EXPECT_EQ(stamps(pairing.addGrid(grid(0.1))), (Stamps{{0.1, 0.1}}));
  // No grid at all: the oldest camera_info is given up with an empty grid once more than
  // kMaxWaitingForFirstGrid wait.
  Pairing empty(0.05);
  for (std::size_t k = 0; k < Pairing::kMaxWaitingForFirstGrid; ++k)
  {
    EXPECT_TRUE(empty.addInfo(info(0.1 * static_cast<double>(k))).empty());
  }
  EXPECT_EQ(stamps(empty.addInfo(info(1.0))), (Stamps{{0.0, -1.0}}));
  EXPECT_EQ(empty.waiting(), Pairing::kMaxWaitingForFirstGrid);
}

TEST(GridForImage, ANegativeToleranceNeverWaits)
{
  Pairing pairing(-1.0);
  EXPECT_EQ(stamps(pairing.addInfo(info(0.0))), (Stamps{{0.0, -1.0}}));
  pairing.addGrid(grid(0.0));
  EXPECT_EQ(stamps(pairing.addInfo(info(0.1))), (Stamps{{0.1, 0.0}}));
  EXPECT_EQ(pairing.waiting(), 0U);
}

TEST(GridForImage, TimeGoingBackwardsStartsAfresh)
{
  Pairing pairing(0.05);
  pairing.addGrid(grid(9.8));
  pairing.addGrid(grid(9.9));
  EXPECT_TRUE(pairing.addInfo(info(10.0)).empty());
  // The bag loops: the waiting camera_info goes with the old grids, which are then forgotten.
  EXPECT_EQ(stamps(pairing.addGrid(grid(0.0))), (Stamps{{10.0, 9.9}}));
  EXPECT_EQ(since(pairing.newestGrid()->header.stamp), 0.0);
  EXPECT_EQ(stamps(pairing.addInfo(info(0.0))), (Stamps{{0.0, 0.0}}));
}

TEST(GridForImage, OnlyTheLatestGridsAreKept)
{
  Pairing pairing(0.05, 2);
  for (double s : {0.0, 0.1, 0.2, 0.3})
  {
    pairing.addGrid(grid(s));
  }
  EXPECT_EQ(stamps(pairing.addInfo(info(0.0))), (Stamps{{0.0, 0.2}}));
  pairing.clear();
  EXPECT_FALSE(pairing.newestGrid());
  EXPECT_TRUE(pairing.addInfo(info(0.4)).empty());
}

}  // namespace
}  // namespace grid_vision_fusion
