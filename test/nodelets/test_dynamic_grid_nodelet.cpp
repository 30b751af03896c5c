// rostest: the dynamic_grid nodelet in a nodelet manager, fed with hand-made clouds and tf from
// a TransformBroadcaster; checks the three outputs (stamps, frames, sizes, values), and that
// NaN points, empty clouds, clouds without float32 x/y/z and missing tf do not stop it.
#include <gtest/gtest.h>

#include <geometry_msgs/TransformStamped.h>
#include <nav_msgs/OccupancyGrid.h>
#include <ros/ros.h>
#include <sensor_msgs/PointCloud2.h>
#include <sensor_msgs/point_cloud2_iterator.h>
#include <tf2_ros/transform_broadcaster.h>

#include <cmath>
#include <functional>
#include <limits>
#include <set>

#include "grid_vision_fusion/DynamicGrid.h"
#include "wait_for.h"

namespace grid_vision_fusion
{
namespace
{
using test::waitFor;
constexpr char kLidarFrame[] = "velodyne";

constexpr double kWallX = 11.05;  // world x of a static wall, 6 m wide

// The scan of the lidar at world x = `lidar_x` (1.73 m above the ground): ground rings around
// it and the wall, in the lidar frame; `nan_every` > 0 makes every n-th point NaN.
sensor_msgs::PointCloud2::Ptr makeCloud(const ros::Time& stamp, const std::string& frame, double lidar_x,
                                        int nan_every = 0)
{
  const double wall = kWallX - lidar_x;
  auto cloud = boost::make_shared<sensor_msgs::PointCloud2>();
  cloud->header.stamp = stamp;
  cloud->header.frame_id = frame;
  sensor_msgs::PointCloud2Modifier modifier(*cloud);
  modifier.setPointCloud2Fields(4, "x", 1, sensor_msgs::PointField::FLOAT32, "y", 1,
                                sensor_msgs::PointField::FLOAT32, "z", 1, sensor_msgs::PointField::FLOAT32,
                                "intensity", 1, sensor_msgs::PointField::FLOAT32);
  std::vector<std::array<float, 3>> points;
  for (int ring = 0; ring < 20; ++ring)
  {
    const double r = 4.0 + ring * 1.5;
    for (int a = 0; a < 720; ++a)
    {
      const double az = a * M_PI / 360.0;
      const double x = r * std::cos(az);
      const double y = r * std::sin(az);
      if (x > wall - 0.1 && std::fabs(y) < 3.0)
      {
        continue;  // behind the wall
      }
      points.push_back({static_cast<float>(x), static_cast<float>(y), -1.73F});
    }
  }
  for (int i = -30; i <= 30; ++i)
  {
    for (int k = 0; k < 8; ++k)
    {
      points.push_back(
          {static_cast<float>(wall), 0.1F * static_cast<float>(i), -1.3F + 0.2F * static_cast<float>(k)});
    }
  }
  modifier.resize(points.size());
  sensor_msgs::PointCloud2Iterator<float> it(*cloud, "x");
  for (std::size_t i = 0; i < points.size(); ++i, ++it)
  {
    const bool nan = nan_every > 0 && i % static_cast<std::size_t>(nan_every) == 0;
    it[0] = nan ? std::numeric_limits<float>::quiet_NaN() : points[i][0];
    it[1] = points[i][1];
    it[2] = points[i][2];
    it[3] = 1.0F;
  }
  return cloud;
}

class DynamicGridNodeletTest : public ::testing::Test
{
protected:
  void SetUp() override
  {
    pub_points_ = nh_.advertise<sensor_msgs::PointCloud2>("points", 10);
    sub_grid_ = nh_.subscribe<DynamicGrid>("grid", 10,
                                           [this](const DynamicGrid::ConstPtr& m) { grids_.push_back(m); });
    sub_occupancy_ = nh_.subscribe<nav_msgs::OccupancyGrid>("grid/occupancy", 10,
                                                            [this](const nav_msgs::OccupancyGrid::ConstPtr& m)
                                                            { occupancies_.push_back(m); });
    sub_cells_ = nh_.subscribe<sensor_msgs::PointCloud2>(
        "grid/cells", 10, [this](const sensor_msgs::PointCloud2::ConstPtr& m) { cells_.push_back(m); });
    ASSERT_TRUE(waitFor(
        [this]
        {
          return pub_points_.getNumSubscribers() > 0 && sub_grid_.getNumPublishers() > 0 &&
                 sub_occupancy_.getNumPublishers() > 0 && sub_cells_.getNumPublishers() > 0;
        },
        30.0))
        << "the dynamic_grid nodelet did not connect to points/grid/grid/occupancy/grid/cells";
  }

  // The vehicle drives along +x at 10 m/s: tf odom <- velodyne at `stamp`, then the cloud.
  void send(const sensor_msgs::PointCloud2::Ptr& cloud, double x)
  {
    geometry_msgs::TransformStamped tf;
    tf.header.stamp = cloud->header.stamp;
    tf.header.frame_id = "odom";
    tf.child_frame_id = kLidarFrame;
    tf.transform.translation.x = x;
    tf.transform.translation.z = 1.73;
    tf.transform.rotation.w = 1.0;
    broadcaster_.sendTransform(tf);
    ros::WallDuration(0.02).sleep();
    pub_points_.publish(cloud);
  }

  bool waitForStamp(const ros::Time& stamp, double timeout_s = 10.0)
  {
    return waitFor(
        [&]
        {
          return !grids_.empty() && grids_.back()->header.stamp == stamp && !occupancies_.empty() &&
                 occupancies_.back()->header.stamp == stamp && !cells_.empty() &&
                 cells_.back()->header.stamp == stamp;
        },
        timeout_s);
  }

  ros::NodeHandle nh_;
  ros::Publisher pub_points_;
  ros::Subscriber sub_grid_;
  ros::Subscriber sub_occupancy_;
  ros::Subscriber sub_cells_;
  tf2_ros::TransformBroadcaster broadcaster_;
  std::vector<DynamicGrid::ConstPtr> grids_;
  std::vector<nav_msgs::OccupancyGrid::ConstPtr> occupancies_;
  std::vector<sensor_msgs::PointCloud2::ConstPtr> cells_;
};

TEST_F(DynamicGridNodeletTest, PublishesAllThreeOutputsAndSurvivesBadInput)
{
  const ros::Time t0 = ros::Time::now();
  ros::Time stamp;
  for (int k = 0; k < 6; ++k)
  {
    stamp = t0 + ros::Duration(0.1 * k);
    send(makeCloud(stamp, kLidarFrame, 0.2 * k), 0.2 * k);
    ASSERT_TRUE(waitForStamp(stamp)) << "no output for scan " << k;
  }

  // DynamicGrid: odom frame, scan stamp, 300 x 300 cells of 0.2 m, centre 15 m ahead of the
  // lidar at x = 1.0 (whole cells), valid distributions.
  const DynamicGrid& grid = *grids_.back();
  EXPECT_EQ(grid.header.frame_id, "odom");
  EXPECT_EQ(grid.info.width, 300U);
  EXPECT_EQ(grid.info.height, 300U);
  EXPECT_FLOAT_EQ(grid.info.resolution, 0.2F);
  EXPECT_NEAR(grid.info.origin.position.x + 30.0, 16.0, 0.1 + 1e-6);
  EXPECT_NEAR(grid.info.origin.position.y + 30.0, 0.0, 0.1 + 1e-6);
  EXPECT_DOUBLE_EQ(grid.info.origin.orientation.w, 1.0);
  const std::size_t n = 300 * 300;
  ASSERT_EQ(grid.p_static.size(), n);
  ASSERT_EQ(grid.p_dynamic.size(), n);
  ASSERT_EQ(grid.p_free.size(), n);
  ASSERT_EQ(grid.p_unknown.size(), n);
  ASSERT_EQ(grid.vx.size(), n);
  ASSERT_EQ(grid.vy.size(), n);
  ASSERT_EQ(grid.v_var_x.size(), n);
  ASSERT_EQ(grid.v_var_y.size(), n);
  for (std::size_t i = 0; i < n; ++i)
  {
    ASSERT_NEAR(grid.p_static[i] + grid.p_dynamic[i] + grid.p_free[i] + grid.p_unknown[i], 1.0F, 1e-4F) << i;
  }
  auto index = [&](double x, double y)
  {
    const auto col = static_cast<std::size_t>(std::floor((x - grid.info.origin.position.x) / 0.2));
    const auto row = static_cast<std::size_t>(std::floor((y - grid.info.origin.position.y) / 0.2));
    return row * 300 + col;
  };
  const std::size_t wall = index(kWallX, 0.05);
  const std::size_t free_cell = index(7.0, 0.05);
  EXPECT_GT(grid.p_static[wall] + grid.p_dynamic[wall], 0.3F);
  EXPECT_GT(grid.p_free[free_cell], grid.p_static[free_cell] + grid.p_dynamic[free_cell]);

  // OccupancyGrid: same geometry, values in {-1} u [0, 100], unknown behind the wall.
  const nav_msgs::OccupancyGrid& occupancy = *occupancies_.back();
  EXPECT_EQ(occupancy.header.frame_id, "odom");
  EXPECT_EQ(occupancy.info.width, 300U);
  EXPECT_DOUBLE_EQ(occupancy.info.origin.position.x, grid.info.origin.position.x);
  ASSERT_EQ(occupancy.data.size(), n);
  for (std::int8_t v : occupancy.data)
  {
    ASSERT_TRUE(v == -1 || (v >= 0 && v <= 100)) << static_cast<int>(v);
  }
  EXPECT_EQ(occupancy.data[index(20.0, 0.05)], -1);
  EXPECT_LT(occupancy.data[free_cell], 50);
  EXPECT_GE(occupancy.data[free_cell], 0);

  // grid/cells: odom frame, the documented fields, points of the wall at the ground height.
  const sensor_msgs::PointCloud2& cells = *cells_.back();
  EXPECT_EQ(cells.header.frame_id, "odom");
  std::set<std::string> names;
  for (const auto& f : cells.fields)
  {
    names.insert(f.name);
    EXPECT_EQ(f.datatype, sensor_msgs::PointField::FLOAT32) << f.name;
  }
  EXPECT_EQ(names, (std::set<std::string>{"x", "y", "z", "rgb", "vx", "vy", "p_dynamic"}));
  ASSERT_GT(cells.width * cells.height, 0U);
  sensor_msgs::PointCloud2ConstIterator<float> x_it(cells, "x");
  sensor_msgs::PointCloud2ConstIterator<float> z_it(cells, "z");
  bool wall_found = false;
  for (; x_it != x_it.end(); ++x_it, ++z_it)
  {
    wall_found = wall_found || std::fabs(*x_it - 11.1F) < 0.15F;
    EXPECT_NEAR(*z_it, 0.0F, 1e-4F);
  }
  EXPECT_TRUE(wall_found);

  // A cloud with NaN points: processed, the valid points used.
  stamp += ros::Duration(0.1);
  send(makeCloud(stamp, kLidarFrame, 1.2, 7), 1.2);
  ASSERT_TRUE(waitForStamp(stamp)) << "no output for the cloud with NaN points";

  // An empty cloud: a prediction step, outputs with its stamp.
  stamp += ros::Duration(0.1);
  auto empty = makeCloud(stamp, kLidarFrame, 1.4);
  sensor_msgs::PointCloud2Modifier(*empty).resize(0);
  send(empty, 1.4);
  ASSERT_TRUE(waitForStamp(stamp)) << "no output for the empty cloud";

  // A cloud without float32 z: dropped with one error, no output for it.
  stamp += ros::Duration(0.1);
  auto no_z = boost::make_shared<sensor_msgs::PointCloud2>();
  no_z->header.stamp = stamp;
  no_z->header.frame_id = kLidarFrame;
  sensor_msgs::PointCloud2Modifier(*no_z).setPointCloud2Fields(3, "x", 1, sensor_msgs::PointField::FLOAT32,
                                                               "y", 1, sensor_msgs::PointField::FLOAT32, "z",
                                                               1, sensor_msgs::PointField::FLOAT64);
  sensor_msgs::PointCloud2Modifier(*no_z).resize(10);
  send(no_z, 1.6);
  EXPECT_FALSE(waitForStamp(stamp, 1.0)) << "a cloud with a float64 z produced a grid";

  // A cloud in a frame without tf: dropped.
  stamp += ros::Duration(0.1);
  pub_points_.publish(makeCloud(stamp, "no_such_frame", 1.8));
  EXPECT_FALSE(waitForStamp(stamp, 1.0)) << "a cloud without tf produced a grid";

  // Still alive.
  stamp += ros::Duration(0.1);
  send(makeCloud(stamp, kLidarFrame, 2.0), 2.0);
  ASSERT_TRUE(waitForStamp(stamp)) << "the nodelet stopped after bad input";
}

}  // namespace
}  // namespace grid_vision_fusion

int main(int argc, char** argv)
{
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_dynamic_grid_nodelet");
  ros::NodeHandle nh;
  return RUN_ALL_TESTS();
}
