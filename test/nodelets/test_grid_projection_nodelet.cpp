// rostest: the grid projection nodelet in a nodelet manager with static tf (see
// grid_projection_nodelet.test), fed hand-made grids and camera_infos; checks the pixels of known
// cells against hand-computed pinhole values, the stamps and frames, time alignment, laziness,
// the overlay image, the refusal of unusable input and a stale grid's image without cells.
#include <gtest/gtest.h>

#include <ros/ros.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>
#include <sensor_msgs/image_encodings.h>
#include <tf2_ros/static_transform_broadcaster.h>
#include <tf2_ros/transform_broadcaster.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <functional>

#include "grid_vision_fusion/DynamicGrid.h"
#include "grid_vision_fusion/ProjectedGrid.h"
#include "wait_for.h"

namespace grid_vision_fusion
{
namespace
{
using test::waitFor;
constexpr std::uint32_t kWidth = 640;
constexpr std::uint32_t kHeight = 480;
constexpr double kFocal = 500.0;
constexpr double kCx = 320.0;
constexpr double kCy = 240.0;
constexpr double kCameraHeight = 1.5;  // camera_optical is 1.5 m above the grid origin, looking along +x
constexpr double kPixelTolerance = 0.01;

/// Expected pixel of world ground point (x, y, 0) for the test camera: optical x = −y,
/// optical y = 1.5 m − z, optical z = x.
std::array<double, 2> expectedPixel(double x, double y)
{
  return {kCx + kFocal * -y / x, kCy + kFocal * kCameraHeight / x};
}

class GridProjectionNodeletTest : public ::testing::Test
{
protected:
  void SetUp() override
  {
    pub_grid_ = nh_.advertise<DynamicGrid>("grid", 10);
    pub_info_ = nh_.advertise<sensor_msgs::CameraInfo>("camera_info", 10);
    pub_image_ = nh_.advertise<sensor_msgs::Image>("image", 10);
    ASSERT_TRUE(waitFor([] { return test::topicAdvertised("/projected_grid"); }, 20.0))
        << "the grid_projection nodelet never advertised /projected_grid";
  }

  void subscribeProjected()
  {
    sub_projected_ = nh_.subscribe<ProjectedGrid>(
        "projected_grid", 10, [this](const ProjectedGrid::ConstPtr& msg) { received_.push_back(msg); });
    ASSERT_TRUE(waitFor(
        [this] { return pub_grid_.getNumSubscribers() > 0 && pub_info_.getNumSubscribers() > 0; }, 10.0))
        << "the nodelet did not subscribe its inputs";
  }

  /// Grid in "world": 100 × 100 cells of 0.2 m, x ∈ [0, 20), y ∈ [−10, 10).
  static DynamicGrid::Ptr makeGrid(const ros::Time& stamp)
  {
    auto grid = boost::make_shared<DynamicGrid>();
    grid->header.stamp = stamp;
    grid->header.frame_id = "world";
    grid->info.resolution = 0.2F;
    grid->info.width = 100;
    grid->info.height = 100;
    grid->info.origin.position.x = 0.0;
    grid->info.origin.position.y = -10.0;
    grid->info.origin.orientation.w = 1.0;
    const std::size_t n = 100 * 100;
    grid->p_static.assign(n, 0.0F);
    grid->p_dynamic.assign(n, 0.0F);
    grid->p_free.assign(n, 0.9F);
    grid->p_unknown.assign(n, 0.1F);
    grid->vx.assign(n, 0.0F);
    grid->vy.assign(n, 0.0F);
    grid->v_var_x.assign(n, 0.0F);
    grid->v_var_y.assign(n, 0.0F);
    setCell(*grid, 18.1, -2.1, 0.9F, 0.05F, 0.F);   // B: static, in view
    setCell(*grid, 0.1, 0.1, 0.9F, 0.05F, 0.F);     // D: 0.1 m ahead, nearer than min_depth
    setCell(*grid, 10.1, 0.1, 0.9F, 0.05F, 0.F);    // A: static, in view
    setCell(*grid, 15.1, 1.1, 0.05F, 0.9F, -10.F);  // C: dynamic, approaching at 10 m/s
    setCell(*grid, 10.1, 9.9, 0.9F, 0.05F, 0.F);    // E: far left, outside the image
    return grid;
  }

  static void setCell(DynamicGrid& grid, double x, double y, float ps, float pd, float vx)
  {
    const auto col = static_cast<std::size_t>(std::floor(x / 0.2));
    const auto row = static_cast<std::size_t>(std::floor((y + 10.0) / 0.2));
    const std::size_t i = row * 100 + col;
    grid.p_static[i] = ps;
    grid.p_dynamic[i] = pd;
    grid.p_free[i] = 1.F - ps - pd;
    grid.p_unknown[i] = 0.F;
    grid.vx[i] = vx;
  }

  static sensor_msgs::CameraInfo::Ptr makeInfo(const ros::Time& stamp,
                                               const std::string& frame = "camera_optical")
  {
    auto info = boost::make_shared<sensor_msgs::CameraInfo>();
    info->header.stamp = stamp;
    info->header.frame_id = frame;
    info->width = kWidth;
    info->height = kHeight;
    info->distortion_model = "plumb_bob";
    info->D.assign(5, 0.0);
    info->K = {kFocal, 0.0, kCx, 0.0, kFocal, kCy, 0.0, 0.0, 1.0};
    info->R = {1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0};
    info->P = {kFocal, 0.0, kCx, 0.0, 0.0, kFocal, kCy, 0.0, 0.0, 0.0, 1.0, 0.0};
    return info;
  }

  /// Publishes `grid` and `info` every 100 ms until a projection with the stamp of `info` came.
  bool projectUntilReceived(const DynamicGrid::Ptr& grid, const sensor_msgs::CameraInfo::Ptr& info,
                            double timeout_s = 10.0)
  {
    return waitFor(
        [&]
        {
          for (const auto& msg : received_)
          {
            if (msg->header.stamp == info->header.stamp)
            {
              return true;
            }
          }
          return false;
        },
        timeout_s,
        [&]
        {
          pub_grid_.publish(grid);
          ros::WallDuration(0.02).sleep();
          pub_info_.publish(info);
        });
  }

  ros::NodeHandle nh_;
  ros::Publisher pub_grid_, pub_info_, pub_image_;
  ros::Subscriber sub_projected_;
  std::vector<ProjectedGrid::ConstPtr> received_;
};

TEST_F(GridProjectionNodeletTest, LazyInputs)
{
  ros::WallDuration(0.5).sleep();
  ros::spinOnce();
  EXPECT_EQ(pub_grid_.getNumSubscribers(), 0U);
  EXPECT_EQ(pub_info_.getNumSubscribers(), 0U);
  EXPECT_EQ(pub_image_.getNumSubscribers(), 0U);
  subscribeProjected();
  ros::WallDuration(0.3).sleep();
  EXPECT_EQ(pub_image_.getNumSubscribers(), 0U) << "image subscribed without an overlay subscriber";
  {
    const boost::function<void(const sensor_msgs::Image::ConstPtr&)> ignore =
        [](const sensor_msgs::Image::ConstPtr&) {};
    ros::Subscriber overlay = nh_.subscribe<sensor_msgs::Image>("projected_grid/image", 1, ignore);
    EXPECT_TRUE(waitFor([this] { return pub_image_.getNumSubscribers() > 0; }, 10.0))
        << "an overlay subscriber must make the nodelet subscribe the image";
  }
  EXPECT_TRUE(waitFor([this] { return pub_image_.getNumSubscribers() == 0; }, 10.0))
      << "image still subscribed after the overlay subscriber left";
  EXPECT_GT(pub_grid_.getNumSubscribers(), 0U);
  sub_projected_.shutdown();
  EXPECT_TRUE(waitFor(
      [this] { return pub_grid_.getNumSubscribers() == 0 && pub_info_.getNumSubscribers() == 0; }, 10.0))
      << "inputs still subscribed after the last output subscriber left";
}

TEST_F(GridProjectionNodeletTest, KnownCellsLandOnTheirPixels)
{
  subscribeProjected();
  const ros::Time image_stamp(1317000000, 500000000);
  const ros::Time grid_stamp = image_stamp - ros::Duration(0.05);
  ASSERT_TRUE(projectUntilReceived(makeGrid(grid_stamp), makeInfo(image_stamp)))
      << "no projected_grid published";
  const ProjectedGrid& msg = *received_.front();
  EXPECT_EQ(msg.header.stamp, image_stamp);
  EXPECT_EQ(msg.header.frame_id, "camera_optical");
  EXPECT_EQ(msg.grid_stamp, grid_stamp);
  EXPECT_EQ(msg.grid_frame_id, "world");
  EXPECT_EQ(msg.image_width, kWidth);
  EXPECT_EQ(msg.image_height, kHeight);
  // Row-major order (rows along +y): B (y = −2.1), A (y = 0.1), C (y = 1.1); D too near, E outside.
  ASSERT_EQ(msg.u.size(), 3U);
  ASSERT_EQ(msg.v.size(), 3U);
  ASSERT_EQ(msg.depth.size(), 3U);
  ASSERT_EQ(msg.state.size(), 3U);
  ASSERT_EQ(msg.p_dynamic.size(), 3U);

  const auto b = expectedPixel(18.1, -2.1);
  EXPECT_NEAR(msg.u[0], b[0], kPixelTolerance);
  EXPECT_NEAR(msg.v[0], b[1], kPixelTolerance);
  EXPECT_NEAR(msg.depth[0], 18.1, 1e-4);
  EXPECT_EQ(msg.state[0], ProjectedGrid::STATIC);

  const auto a = expectedPixel(10.1, 0.1);  // (315.05, 314.26)
  EXPECT_NEAR(msg.u[1], a[0], kPixelTolerance);
  EXPECT_NEAR(msg.v[1], a[1], kPixelTolerance);
  EXPECT_NEAR(msg.x[1], 10.1, 1e-4);
  EXPECT_NEAR(msg.y[1], 0.1, 1e-4);
  EXPECT_FLOAT_EQ(msg.p_static[1], 0.9F);
  EXPECT_EQ(msg.state[1], ProjectedGrid::STATIC);

  // C moved 10 m/s × 50 ms = 0.5 m towards the camera between the scan and the image.
  const auto c = expectedPixel(14.6, 1.1);  // (282.33, 291.37)
  EXPECT_NEAR(msg.u[2], c[0], kPixelTolerance);
  EXPECT_NEAR(msg.v[2], c[1], kPixelTolerance);
  EXPECT_NEAR(msg.x[2], 14.6, 1e-4);
  EXPECT_NEAR(msg.depth[2], 14.6, 1e-4);
  EXPECT_FLOAT_EQ(msg.vx[2], -10.F);
  EXPECT_EQ(msg.state[2], ProjectedGrid::DYNAMIC);

  // Every later message carries its own camera_info stamp.
  const ros::Time second_stamp = image_stamp + ros::Duration(0.1);
  ASSERT_TRUE(projectUntilReceived(makeGrid(second_stamp - ros::Duration(0.02)), makeInfo(second_stamp)));
  EXPECT_EQ(received_.back()->header.stamp, second_stamp);
}

TEST_F(GridProjectionNodeletTest, UnusableInputGivesNoOutputAndNoCrash)
{
  subscribeProjected();
  const ros::Time stamp(1317000100, 0);
  auto no_p = makeInfo(stamp);
  no_p->P.fill(0.0);
  auto zero_focal = makeInfo(stamp + ros::Duration(0.01));
  zero_focal->P[0] = 0.0;
  auto unknown_frame = makeInfo(stamp + ros::Duration(0.02), "no_such_camera_frame");
  auto stale = makeInfo(stamp + ros::Duration(2.0));  // the grid is 2 s old: above max_grid_age
  auto bad_grid = makeGrid(stamp);
  bad_grid->vx.pop_back();
  auto nan_grid = makeGrid(stamp);
  nan_grid->info.resolution = std::nanf("");
  const auto grid = makeGrid(stamp);
  const ros::WallTime end = ros::WallTime::now() + ros::WallDuration(1.5);
  while (ros::WallTime::now() < end)
  {
    pub_grid_.publish(grid);
    ros::WallDuration(0.02).sleep();
    for (const auto& info : {no_p, zero_focal, unknown_frame, stale})
    {
      pub_info_.publish(info);
    }
    ros::WallDuration(0.1).sleep();
    ros::spinOnce();
  }
  // A grid 2 s old says too little of the image's scene: its image is published without cells
  // (its boxes come out placed by their tracks), the others not at all.
  ASSERT_FALSE(received_.empty()) << "no output for the camera_info with a stale grid";
  for (const auto& projected : received_)
  {
    EXPECT_EQ(projected->header.stamp, stale->header.stamp)
        << "unusable camera_info or missing tf produced output";
    EXPECT_TRUE(projected->u.empty()) << "the cells of a stale grid were projected";
    EXPECT_EQ(projected->grid_stamp, stamp);
  }
  received_.clear();

  // Malformed grids are dropped: the good grid published above stays the latest one... until
  // the nodelet drops the bad ones, which must not replace it.
  pub_grid_.publish(bad_grid);
  pub_grid_.publish(nan_grid);
  ros::WallDuration(0.3).sleep();
  const ros::Time good = stamp + ros::Duration(0.03);
  auto info = makeInfo(good);
  // (Stale camera_infos still queued may come out first, without cells.)
  auto output_for_good = [&]
  {
    const auto it =
        std::find_if(received_.begin(), received_.end(),
                     [&](const ProjectedGrid::ConstPtr& msg) { return msg->header.stamp == good; });
    return it == received_.end() ? ProjectedGrid::ConstPtr() : *it;
  };
  EXPECT_TRUE(waitFor([&] { return output_for_good() != nullptr; }, 10.0, [&] { pub_info_.publish(info); }))
      << "no output after unusable input (malformed grids must not replace the good one)";
  const ProjectedGrid::ConstPtr projected = output_for_good();
  ASSERT_TRUE(projected);
  EXPECT_EQ(projected->u.size(), 3U);
}

TEST_F(GridProjectionNodeletTest, CameraInfoBeforeItsTfWaitsAndIsProjected)
{
  // The camera_info of a moving camera frame arrives before the /tf of its stamp (as in a bag
  // replay where camera_info precedes /tf): the nodelet must keep it until the tf comes, then
  // project it, instead of dropping it with "extrapolation into the future".
  subscribeProjected();
  const ros::Time stamp(1317000300, 0);
  const auto grid = makeGrid(stamp - ros::Duration(0.05));
  // Make sure the grid is there first (a camera_info before any grid is refused).
  ASSERT_TRUE(projectUntilReceived(grid, makeInfo(stamp - ros::Duration(0.03))));
  const auto late = [this, stamp]
  {
    std::vector<ProjectedGrid::ConstPtr> out;
    for (const auto& msg : received_)
    {
      if (msg->header.stamp == stamp)
      {
        out.push_back(msg);
      }
    }
    return out;
  };
  const auto info = makeInfo(stamp, "camera_late");
  pub_info_.publish(info);
  ros::WallDuration(0.5).sleep();
  ros::spinOnce();
  EXPECT_TRUE(late().empty()) << "projected before the tf of its stamp existed";
  // Now the tf world -> camera_late (the test camera pose) at and around the stamp.
  tf2_ros::TransformBroadcaster broadcaster;
  std::vector<geometry_msgs::TransformStamped> transforms;
  for (double dt : {-0.1, 0.0, 0.1})
  {
    geometry_msgs::TransformStamped camera;
    camera.header.stamp = stamp + ros::Duration(dt);
    camera.header.frame_id = "world";
    camera.child_frame_id = "camera_late";
    camera.transform.translation.z = kCameraHeight;
    camera.transform.rotation.x = -0.5;
    camera.transform.rotation.y = 0.5;
    camera.transform.rotation.z = -0.5;
    camera.transform.rotation.w = 0.5;
    transforms.push_back(camera);
  }
  ASSERT_TRUE(waitFor([&] { return !late().empty(); }, 10.0,
                      [&]
                      {
                        broadcaster.sendTransform(transforms);
                        ros::WallDuration(0.05).sleep();
                      }))
      << "the camera_info waiting for its tf was never projected";
  ros::WallDuration(0.3).sleep();
  ros::spinOnce();
  const auto projected = late();
  ASSERT_EQ(projected.size(), 1U) << "the camera_info must be projected exactly once";
  EXPECT_EQ(projected.front()->header.frame_id, "camera_late");
  ASSERT_EQ(projected.front()->u.size(), 3U);
  const auto a = expectedPixel(10.1, 0.1);
  EXPECT_NEAR(projected.front()->u[1], a[0], kPixelTolerance);
  EXPECT_NEAR(projected.front()->v[1], a[1], kPixelTolerance);
}

TEST_F(GridProjectionNodeletTest, CameraInfoBeforeTheGridOfItsSweepWaitsForIt)
{
  // Live (or a bag played at its rate) the image of a sweep arrives while the grid of that sweep
  // is still being computed: it must be projected with that grid, not with the previous sweep's.
  subscribeProjected();
  const ros::Time stamp(1317000400, 0);
  const auto previous = makeGrid(stamp - ros::Duration(0.1));
  ASSERT_TRUE(projectUntilReceived(previous, makeInfo(stamp - ros::Duration(0.1))));
  const auto projected_at = [this](const ros::Time& t)
  {
    std::vector<ProjectedGrid::ConstPtr> out;
    for (const auto& msg : received_)
    {
      if (msg->header.stamp == t)
      {
        out.push_back(msg);
      }
    }
    return out;
  };
  pub_info_.publish(makeInfo(stamp));
  ros::WallDuration(0.5).sleep();
  ros::spinOnce();
  EXPECT_TRUE(projected_at(stamp).empty()) << "projected with the previous sweep's grid";
  const auto own = makeGrid(stamp);
  ASSERT_TRUE(waitFor([&] { return !projected_at(stamp).empty(); }, 10.0,
                      [&]
                      {
                        pub_grid_.publish(own);
                        ros::WallDuration(0.05).sleep();
                      }))
      << "the camera_info waiting for its grid was never projected";
  EXPECT_EQ(projected_at(stamp).front()->grid_stamp, stamp);

  // The lidar stops: the next camera_info ends the wait, and the waiting one is projected with
  // the newest grid there is (moved to its stamp).
  const ros::Time late = stamp + ros::Duration(0.1);
  const ros::Time next = stamp + ros::Duration(0.2);
  pub_info_.publish(makeInfo(late));
  ros::WallDuration(0.3).sleep();
  ros::spinOnce();
  EXPECT_TRUE(projected_at(late).empty()) << "did not wait for the grid of its sweep";
  ASSERT_TRUE(waitFor([&] { return !projected_at(late).empty(); }, 10.0,
                      [&]
                      {
                        pub_info_.publish(makeInfo(next));
                        ros::WallDuration(0.05).sleep();
                      }))
      << "the next camera_info did not end the wait";
  EXPECT_EQ(projected_at(late).front()->grid_stamp, stamp);
}

TEST_F(GridProjectionNodeletTest, OverlayShowsStaticBlueAndDynamicGreen)
{
  std::vector<sensor_msgs::Image::ConstPtr> overlays;
  ros::Subscriber sub_overlay = nh_.subscribe<sensor_msgs::Image>(
      "projected_grid/image", 10, [&](const sensor_msgs::Image::ConstPtr& m) { overlays.push_back(m); });
  ASSERT_TRUE(waitFor(
      [this] { return pub_image_.getNumSubscribers() > 0 && pub_info_.getNumSubscribers() > 0; }, 10.0));
  const ros::Time stamp(1317000200, 250);
  auto image = boost::make_shared<sensor_msgs::Image>();
  image->header.stamp = stamp;
  image->header.frame_id = "camera_optical";
  image->width = kWidth;
  image->height = kHeight;
  image->encoding = sensor_msgs::image_encodings::RGB8;
  image->step = kWidth * 3;
  image->data.assign(image->step * kHeight, 0);
  const auto grid = makeGrid(stamp - ros::Duration(0.05));
  const auto info = makeInfo(stamp);
  ASSERT_TRUE(waitFor([&] { return !overlays.empty(); }, 10.0,
                      [&]
                      {
                        pub_image_.publish(image);
                        pub_grid_.publish(grid);
                        ros::WallDuration(0.02).sleep();
                        pub_info_.publish(info);
                      }))
      << "no overlay published";
  const sensor_msgs::Image& overlay = *overlays.front();
  EXPECT_EQ(overlay.header.stamp, stamp);
  EXPECT_EQ(overlay.encoding, sensor_msgs::image_encodings::BGR8);
  ASSERT_EQ(overlay.width, kWidth);
  ASSERT_EQ(overlay.height, kHeight);
  auto pixel = [&](double u, double v)
  {
    const std::size_t i = static_cast<std::size_t>(v) * overlay.step + static_cast<std::size_t>(u) * 3;
    return std::array<int, 3>{overlay.data[i], overlay.data[i + 1], overlay.data[i + 2]};
  };
  const auto a = expectedPixel(10.1, 0.1);
  const auto c = expectedPixel(14.6, 1.1);
  EXPECT_EQ(pixel(a[0], a[1]), (std::array<int, 3>{255, 0, 0}));  // static: blue (BGR)
  EXPECT_EQ(pixel(c[0], c[1]), (std::array<int, 3>{0, 200, 0}));  // dynamic: green
  EXPECT_EQ(pixel(10, 10), (std::array<int, 3>{0, 0, 0}));        // untouched background
}

}  // namespace
}  // namespace grid_vision_fusion

int main(int argc, char** argv)
{
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_grid_projection_nodelet");
  ros::NodeHandle nh;
  // Static tf: a camera 1.5 m above the grid frame origin looking along +x (optical frame: x right
  // = −y, y down = −z, z forward = +x), and a "velodyne" 1.73 m above the origin, so the default
  // ground_frame velo_link and ground_height −1.73 put the ground plane at z = 0 of "world".
  tf2_ros::StaticTransformBroadcaster broadcaster;
  geometry_msgs::TransformStamped camera;
  camera.header.frame_id = "world";
  camera.child_frame_id = "camera_optical";
  camera.transform.translation.z = 1.5;
  camera.transform.rotation.x = -0.5;
  camera.transform.rotation.y = 0.5;
  camera.transform.rotation.z = -0.5;
  camera.transform.rotation.w = 0.5;
  geometry_msgs::TransformStamped velodyne;
  velodyne.header.frame_id = "world";
  velodyne.child_frame_id = "velo_link";
  velodyne.transform.translation.z = 1.73;
  velodyne.transform.rotation.w = 1.0;
  broadcaster.sendTransform(std::vector<geometry_msgs::TransformStamped>{camera, velodyne});
  return RUN_ALL_TESTS();
}
