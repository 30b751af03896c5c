// The four stage classes without a master: tf from a hand-fed tf2::BufferCore, messages built
// here. What the nodelets and the offline Pipeline rely on: a stage refuses unusable input with
// the exception its callers count, and turns good input into the message of its output topic.
#include <gtest/gtest.h>

#include <geometry_msgs/TransformStamped.h>
#include <sensor_msgs/point_cloud2_iterator.h>
#include <tf2/exceptions.h>

#include <cmath>

#include "grid_vision_fusion/ros/fusion_conversions.h"
#include "grid_vision_fusion/ros/projection_conversions.h"
#include "grid_vision_fusion/ros/sensor_views.h"
#include "grid_vision_fusion/ros_stages/detector_stage.h"
#include "grid_vision_fusion/ros_stages/fusion_stage.h"
#include "grid_vision_fusion/ros_stages/grid_stage.h"
#include "grid_vision_fusion/ros_stages/projection_stage.h"

namespace grid_vision_fusion
{
namespace
{
const ros::Time kStamp(1317042000, 0);

geometry_msgs::TransformStamped transform(const std::string& parent, const std::string& child, double x,
                                          double z, const ros::Time& stamp, double qx = 0.0, double qy = 0.0,
                                          double qz = 0.0, double qw = 1.0)
{
  geometry_msgs::TransformStamped t;
  t.header.frame_id = parent;
  t.header.stamp = stamp;
  t.child_frame_id = child;
  t.transform.translation.x = x;
  t.transform.translation.z = z;
  t.transform.rotation.x = qx;
  t.transform.rotation.y = qy;
  t.transform.rotation.z = qz;
  t.transform.rotation.w = qw;
  return t;
}

/// A cloud in `frame` with a wall of points `distance` ahead of the sensor (x, y, z float32):
/// every other point on the ground 1.73 m below the sensor, the others 1.2 m above it.
sensor_msgs::PointCloud2 wallCloud(const std::string& frame, float distance = 10.0F)
{
  sensor_msgs::PointCloud2 cloud;
  cloud.header.stamp = kStamp;
  cloud.header.frame_id = frame;
  sensor_msgs::PointCloud2Modifier modifier(cloud);
  modifier.setPointCloud2FieldsByString(1, "xyz");
  modifier.resize(200);
  sensor_msgs::PointCloud2Iterator<float> x(cloud, "x"), y(cloud, "y"), z(cloud, "z");
  for (int i = 0; i < 200; ++i, ++x, ++y, ++z)
  {
    *x = distance;
    *y = -2.0F + 0.02F * static_cast<float>(i);
    *z = i % 2 == 0 ? -1.73F : -0.53F;
  }
  return cloud;
}

TEST(GridStage, UpdatesFromTfAndPublishesInTheFixedFrame)
{
  DynamicGridParams params;
  params.filter.particle_count = 1 << 12;
  GridStage stage(params);
  tf2::BufferCore tf;
  tf.setTransform(transform("odom", "velo_link", 5.0, 1.73, kStamp), "test", true);

  const DynamicGridCycle cycle = stage.update(wallCloud("velo_link"), tf);
  EXPECT_EQ(cycle.sensor.points, 200U);
  const DynamicGrid::Ptr grid = stage.gridMsg();
  EXPECT_EQ(grid->header.frame_id, "odom");
  EXPECT_EQ(grid->header.stamp, kStamp);
  EXPECT_EQ(grid->p_static.size(), static_cast<std::size_t>(params.filter.width * params.filter.height));
  EXPECT_EQ(stage.occupancyMsg()->header.stamp, kStamp);
  EXPECT_EQ(stage.cellsMsg()->header.frame_id, "odom");
  // The cells' ages: 0 where the wall's points fell (x = 15 m in the world: the cell before or
  // after that edge), 255 where no point ever did; one scan later, the wall 2 m farther, 1.
  ASSERT_EQ(grid->scans_since_hit.size(), grid->p_static.size());
  const auto ageAt = [](const DynamicGrid& g, double x, double y)
  {
    const auto col = static_cast<std::size_t>((x - g.info.origin.position.x) / g.info.resolution);
    const auto row = static_cast<std::size_t>((y - g.info.origin.position.y) / g.info.resolution);
    return static_cast<int>(g.scans_since_hit.at(row * g.info.width + col));
  };
  EXPECT_EQ(std::min(ageAt(*grid, 14.9, 0.1), ageAt(*grid, 15.1, 0.1)), 0);
  EXPECT_EQ(ageAt(*grid, 25.1, 5.1), 255);
  // The ground under each cell as the scan shows it: the wall's ground points lie 1.73 m below
  // the lidar, at z = 0 of odom; beyond the sensor model's range it is unknown.
  ASSERT_EQ(grid->ground_z.size(), grid->p_static.size());
  const auto groundAt = [](const DynamicGrid& g, double x, double y)
  {
    const auto col = static_cast<std::size_t>((x - g.info.origin.position.x) / g.info.resolution);
    const auto row = static_cast<std::size_t>((y - g.info.origin.position.y) / g.info.resolution);
    return g.ground_z.at(row * g.info.width + col);
  };
  EXPECT_NEAR(groundAt(*grid, 10.1, 0.1), 0.0, 1e-3);
  sensor_msgs::PointCloud2 farther = wallCloud("velo_link", 12.0F);
  farther.header.stamp = kStamp + ros::Duration(0.1);
  tf.setTransform(transform("odom", "velo_link", 5.0, 1.73, farther.header.stamp), "test", true);
  stage.update(farther, tf);
  const DynamicGrid::Ptr later = stage.gridMsg();
  EXPECT_EQ(std::min(ageAt(*later, 14.9, 0.1), ageAt(*later, 15.1, 0.1)), 1);
  EXPECT_EQ(std::min(ageAt(*later, 16.9, 0.1), ageAt(*later, 17.1, 0.1)), 0);
}

TEST(GridStage, RefusesACloudWithoutFloatFieldsOrWithoutTf)
{
  DynamicGridParams params;
  params.filter.particle_count = 1 << 12;
  GridStage stage(params);
  tf2::BufferCore tf;
  sensor_msgs::PointCloud2 no_z = wallCloud("velo_link");
  no_z.fields.pop_back();
  EXPECT_THROW(stage.update(no_z, tf), UnusableMessage);
  EXPECT_THROW(stage.update(wallCloud("velo_link"), tf), tf2::TransformException);
  EXPECT_FALSE(stage.filter().initialised()) << "a refused scan must leave the filter untouched";
}

TEST(ProjectionStage, SkipsWithTheReasonAndProjectsOnceTfIsThere)
{
  GridProjectionParams params;
  params.ground_frame = "";
  params.ground_height = 0.0;
  ProjectionStage stage(params);
  EXPECT_EQ(stage.tfFrames("world"), std::vector<std::string>{"world"});

  DynamicGrid grid;
  grid.header.stamp = kStamp;
  grid.header.frame_id = "world";
  grid.info.resolution = 1.0F;
  grid.info.width = 4;
  grid.info.height = 4;
  grid.info.origin.position.x = 8.0;
  grid.info.origin.position.y = -2.0;
  grid.info.origin.orientation.w = 1.0;
  for (auto* array : {&grid.p_static, &grid.p_dynamic, &grid.p_free, &grid.p_unknown, &grid.vx, &grid.vy,
                      &grid.v_var_x, &grid.v_var_y})
  {
    array->assign(16, 0.0F);
  }
  grid.p_static.assign(16, 0.9F);
  sensor_msgs::CameraInfo info;
  info.header.stamp = kStamp;
  info.header.frame_id = "camera";
  info.width = 640;
  info.height = 480;
  info.P = {500.0, 0.0, 320.0, 0.0, 0.0, 500.0, 240.0, 0.0, 0.0, 0.0, 1.0, 0.0};

  tf2::BufferCore tf;
  EXPECT_THROW(stage.project(grid, info, tf), ProjectionSkipped);  // no tf camera <- world
  // The optical frame looks along world +x from 1.5 m above the ground (x right = -y, y down = -z).
  tf.setTransform(transform("world", "camera", 0.0, 1.5, kStamp, -0.5, 0.5, -0.5, 0.5), "test", true);
  const ProjectedGrid::Ptr projected = stage.project(grid, info, tf);
  EXPECT_EQ(projected->header.stamp, kStamp);
  EXPECT_EQ(projected->header.frame_id, "camera");
  EXPECT_EQ(projected->grid_frame_id, "world");
  EXPECT_EQ(projected->resolution, 1.0F) << "the grid's cell size, for the fusion's scan registration";
  EXPECT_GT(projected->u.size(), 0U);
  EXPECT_TRUE(projected->scans_since_hit.empty()) << "the grid carried no ages";
  // With the cells' ages, every point carries its cell's.
  DynamicGrid aged = grid;
  aged.scans_since_hit.assign(16, 3);
  const ProjectedGrid::Ptr aged_projected = stage.project(aged, info, tf);
  ASSERT_EQ(aged_projected->scans_since_hit.size(), aged_projected->u.size());
  EXPECT_EQ(aged_projected->scans_since_hit.front(), 3);
  aged.scans_since_hit.resize(15);
  EXPECT_NE(checkDynamicGrid(aged).find("scans_since_hit has 15"), std::string::npos)
      << checkDynamicGrid(aged);
  DynamicGrid grounded = grid;
  grounded.ground_z.assign(3, 0.0F);
  EXPECT_NE(checkDynamicGrid(grounded).find("ground_z has 3"), std::string::npos)
      << checkDynamicGrid(grounded);
  // Where the image meets the ground, for the boxes without cells: the world point (10, 2, 0)
  // lies 10 m ahead and 2 m left, 1.5 m below the camera: u = 320 - 500 * 2 / 10, v = 240 + 75.
  const ImageGround ground = imageGroundOf(*projected);
  ASSERT_TRUE(ground.valid());
  EXPECT_DOUBLE_EQ(projected->ground_z, 0.0F);
  const Eigen::Vector2d foot = ground.groundPoint(220.0, 315.0, 150.0);
  EXPECT_NEAR(foot.x(), 10.0, 1e-6);
  EXPECT_NEAR(foot.y(), 2.0, 1e-6);

  // A grid 2 s older than the image says too little of its scene: no cell of it is projected, the
  // geometry is (the fusion places the image's boxes with it), and the notes say why.
  DynamicGrid old_grid = grid;
  old_grid.header.stamp = kStamp - ros::Duration(2.0);
  ProjectionNotes notes;
  const ProjectedGrid::Ptr without_cells = stage.project(old_grid, info, tf, &notes);
  EXPECT_TRUE(without_cells->u.empty()) << "cells of a grid 2 s older than the image were projected";
  EXPECT_TRUE(without_cells->x.empty() && without_cells->state.empty());
  EXPECT_NE(notes.cells_left_out.find("max_grid_age"), std::string::npos) << notes.cells_left_out;
  EXPECT_EQ(without_cells->header.stamp, kStamp);
  EXPECT_EQ(without_cells->grid_stamp, old_grid.header.stamp) << "the planner sees how old the grid was";
  EXPECT_EQ(without_cells->grid_to_image, projected->grid_to_image);
  EXPECT_TRUE(imageGroundOf(*without_cells).valid());
  // Grids that come 0.8 s apart (a grid stage slower than its lidar): the newest one may be three
  // such intervals old; beyond that the stream has stalled.
  EXPECT_DOUBLE_EQ(stage.maxGridAge(0.1), stage.params().max_grid_age);
  EXPECT_DOUBLE_EQ(stage.maxGridAge(0.8), 2.4);
  EXPECT_EQ(stage.project(old_grid, info, tf, &notes, 0.8)->u.size(), projected->u.size());
  EXPECT_TRUE(notes.cells_left_out.empty()) << notes.cells_left_out;
  EXPECT_TRUE(stage.project(old_grid, info, tf, &notes, 0.6)->u.empty())
      << "cells of a grid 2 s older than the image were projected with grids 0.6 s apart";
  EXPECT_NE(notes.cells_left_out.find("grid intervals (1.8"), std::string::npos) << notes.cells_left_out;
  sensor_msgs::CameraInfo uncalibrated = info;
  uncalibrated.P.fill(0.0);
  EXPECT_THROW(stage.project(grid, uncalibrated, tf), ProjectionSkipped);
}

TEST(DetectorStage, ReplaysLabelsInStepWithTheImagesAndOneThresholdServesBothBackends)
{
  DetectorParams params;
  params.backend = "replay";
  params.replay.directory = std::string(GVF_TEST_DATA_DIR) + "/kitti_labels/label_2";
  params.replay.missing_file_is_empty = true;
  DetectorStage stage(params);
  EXPECT_FALSE(stage.detector().needsPixels());

  auto image = boost::make_shared<sensor_msgs::Image>();
  image->width = 1242;
  image->height = 375;
  image->encoding = "16UC1";  // the replay does not look at the pixels
  EXPECT_EQ(stage.frameIndex(*image), 0);
  EXPECT_EQ(stage.frameIndex(*image), 1);  // counted at arrival, also for an image dropped later
  const std::vector<Detection> detections = stage.detect(image, 0);
  EXPECT_FALSE(detections.empty());
  stage.setThresholds(1.0, 0.45);  // labels score 1.0: still kept at a threshold of 1
  EXPECT_EQ(stage.detect(image, 0).size(), detections.size());
  EXPECT_THROW(stage.setThresholds(1.5, 0.45), std::invalid_argument);

  params.backend = "magic";
  EXPECT_THROW(DetectorStage{params}, std::invalid_argument);
}

TEST(DetectorStage, TheImageViewChecksEncodingStepAndDataLength)
{
  sensor_msgs::Image image;
  image.encoding = "rgb8";
  image.width = 4;
  image.height = 3;
  image.step = 12;
  image.data.assign(36, 7);
  cv::Mat pixels;
  PixelFormat format = PixelFormat::kBgr8;
  ASSERT_EQ(imageViewOf(image, pixels, format), "");
  EXPECT_EQ(format, PixelFormat::kRgb8);
  EXPECT_EQ(pixels.type(), CV_8UC3);
  EXPECT_EQ(pixels.data, image.data.data());  // a view, not a copy
  EXPECT_EQ(pixels.step, 12U);

  image.data.resize(35);  // the last row one byte short
  EXPECT_NE(imageViewOf(image, pixels, format).find("data holds 35 bytes, step * height needs 36"),
            std::string::npos);
  image.step = 11;  // shorter than a row of 4 rgb8 pixels
  EXPECT_NE(imageViewOf(image, pixels, format).find("step 11 < width"), std::string::npos);
  image.encoding = "rgba8";
  EXPECT_NE(imageViewOf(image, pixels, format).find("\"rgba8\" is not supported"), std::string::npos);
  image.encoding = "mono8";
  image.height = 0;
  EXPECT_NE(imageViewOf(image, pixels, format).find("image is empty"), std::string::npos);
}

TEST(FusionStage, FusesAPairAndRefusesAnInvalidConfiguration)
{
  FusionParams per_frame;  // the paper's output: no tracker, the median position
  per_frame.tracking = false;
  per_frame.fusion.position = PositionSource::kMedian;
  FusionStage stage(per_frame);
  Detection2DArray detections;
  detections.header.stamp = kStamp;
  detections.header.frame_id = "camera";
  detections.image_width = 640;
  detections.image_height = 480;
  Detection2D box;
  box.label = "car";
  box.score = 0.9F;
  box.x_min = 100.F;
  box.y_min = 100.F;
  box.x_max = 200.F;
  box.y_max = 200.F;
  detections.detections.push_back(box);
  ProjectedGrid grid;
  grid.header = detections.header;
  grid.grid_frame_id = "world";
  grid.image_width = 640;
  grid.image_height = 480;
  for (auto* array :
       {&grid.u, &grid.v, &grid.depth, &grid.x, &grid.y, &grid.vx, &grid.vy, &grid.p_static, &grid.p_dynamic})
  {
    array->assign(3, 0.F);
  }
  grid.u = {150.F, 160.F, 170.F};
  grid.v = {200.F, 201.F, 202.F};
  grid.x = {12.F, 12.2F, 12.4F};
  grid.state.assign(3, ProjectedGrid::STATIC);

  const FusedPair pair = stage.fuse(detections, grid);
  ASSERT_EQ(pair.objects->objects.size(), 1U);
  EXPECT_EQ(pair.objects->objects[0].motion, DetectedObject::MOTION_STATIC);
  EXPECT_NEAR(pair.objects->objects[0].position.x, 12.2, 1e-5);
  EXPECT_EQ(pair.objects->header.frame_id, "world");

  grid.image_width = 1242;
  EXPECT_THROW(stage.fuse(detections, grid), std::invalid_argument);  // sizes differ

  FusionConfig bad = stage.config();
  bad.min_points = 0;
  EXPECT_THROW(stage.setConfig(bad), std::invalid_argument);
  EXPECT_EQ(stage.config().min_points, FusionConfig{}.min_points)
      << "a refused configuration changes nothing";

  // With the defaults the stage tracks: the first pair starts a tentative track, published as
  // such, the next ones publish it confirmed with the same track id; the centre lies beyond the
  // cells seen from the camera at the origin.
  FusionStage tracked(FusionParams{});
  grid.image_width = 640;
  std::uint32_t id = 0;
  for (int k = 0; k < 4; ++k)
  {
    detections.header.stamp = kStamp + ros::Duration(0.1 * k);
    grid.header.stamp = detections.header.stamp;
    const FusedPair p = tracked.fuse(detections, grid);
    ASSERT_EQ(p.objects->objects.size(), 1U) << "pair " << k;
    EXPECT_EQ(p.objects->objects[0].track_state,
              k == 0 ? DetectedObject::TRACK_TENTATIVE : DetectedObject::TRACK_CONFIRMED);
    EXPECT_GE(p.objects->objects[0].p_dynamic, 0.F);
    EXPECT_LE(p.objects->objects[0].p_dynamic, 1.F);
    id = k == 0 ? p.objects->objects[0].id : id;
    EXPECT_EQ(p.objects->objects[0].id, id);
    EXPECT_GT(p.objects->objects[0].position.x, 12.4);
  }
  EXPECT_GE(id, 1U);
  EXPECT_EQ(tracked.tracker().size(), 1U);

  // A projected grid without cells (the grid too old for the image) still gives the image's
  // object: its track's, placed by the track, motion unknown. The camera at 1.5 m looks along +x.
  ProjectedGrid without_cells;
  without_cells.header = grid.header;
  without_cells.header.stamp += ros::Duration(0.1);
  without_cells.grid_stamp = grid.header.stamp - ros::Duration(2.0);
  without_cells.grid_frame_id = grid.grid_frame_id;
  without_cells.image_width = grid.image_width;
  without_cells.image_height = grid.image_height;
  without_cells.grid_to_image = {320.0, -500.0, 0.0, 0.0, 240.0, 0.0, -500.0, 750.0, 1.0, 0.0, 0.0, 0.0};
  detections.header.stamp = without_cells.header.stamp;
  const FusedPair unsupported = tracked.fuse(detections, without_cells);
  ASSERT_EQ(unsupported.objects->objects.size(), 1U);
  const DetectedObject& object = unsupported.objects->objects[0];
  EXPECT_EQ(object.id, id);
  EXPECT_EQ(object.position_source, DetectedObject::POSITION_FROM_TRACK);
  EXPECT_EQ(object.motion, DetectedObject::MOTION_UNKNOWN);
  EXPECT_GT(object.position.x, 12.4);
}

}  // namespace
}  // namespace grid_vision_fusion
