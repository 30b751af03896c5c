// rostest: the fusion nodelet in a nodelet manager, fed with hand-made detections and
// projected grids; checks every output field, stamps, frames, laziness, the overlay and the
// handling of malformed input.
#include <gtest/gtest.h>

#include <nodelet/NodeletLoad.h>
#include <ros/ros.h>
#include <rosgraph_msgs/Log.h>
#include <sensor_msgs/Image.h>
#include <sensor_msgs/image_encodings.h>
#include <visualization_msgs/MarkerArray.h>

#include <algorithm>
#include <cmath>
#include <functional>

#include "grid_vision_fusion/DetectedObjectArray.h"
#include "grid_vision_fusion/Detection2DArray.h"
#include "grid_vision_fusion/ProjectedGrid.h"
#include "wait_for.h"

namespace grid_vision_fusion
{
namespace
{
using test::waitFor;
constexpr std::uint32_t kWidth = 640;
constexpr std::uint32_t kHeight = 480;

Detection2D makeBox(std::uint32_t class_id, const std::string& label, float score, float x_min, float y_min,
                    float x_max, float y_max)
{
  Detection2D d;
  d.class_id = class_id;
  d.label = label;
  d.score = score;
  d.x_min = x_min;
  d.y_min = y_min;
  d.x_max = x_max;
  d.y_max = y_max;
  return d;
}

void addPoint(ProjectedGrid& grid, float u, float v, float x, float y, float vx, float vy, std::uint8_t state)
{
  grid.u.push_back(u);
  grid.v.push_back(v);
  grid.depth.push_back(x);
  grid.x.push_back(x);
  grid.y.push_back(y);
  grid.vx.push_back(vx);
  grid.vy.push_back(vy);
  grid.p_static.push_back(state == ProjectedGrid::STATIC ? 0.9F : 0.05F);
  grid.p_dynamic.push_back(state == ProjectedGrid::DYNAMIC ? 0.9F : 0.05F);
  grid.state.push_back(state);
}

class FusionNodeletTest : public ::testing::Test
{
protected:
  void SetUp() override
  {
    pub_detections_ = nh_.advertise<Detection2DArray>("detections", 10);
    pub_grid_ = nh_.advertise<ProjectedGrid>("projected_grid", 10);
    pub_image_ = nh_.advertise<sensor_msgs::Image>("image", 10);
    ASSERT_TRUE(waitFor([] { return test::topicAdvertised("/objects"); }, 20.0))
        << "the fusion nodelet never advertised /objects";
  }

  void subscribeObjects()
  {
    sub_objects_ = nh_.subscribe<DetectedObjectArray>(
        "objects", 10, [this](const DetectedObjectArray::ConstPtr& msg) { received_.push_back(msg); });
    ASSERT_TRUE(waitFor(
        [this] { return pub_detections_.getNumSubscribers() > 0 && pub_grid_.getNumSubscribers() > 0; },
        10.0))
        << "the fusion nodelet did not subscribe its inputs";
  }

  /// Detections for `stamp`: a dynamic car on the left and a static van on the right, plus a
  /// truck whose region holds no point.
  Detection2DArray::Ptr makeDetections(const ros::Time& stamp) const
  {
    auto msg = boost::make_shared<Detection2DArray>();
    msg->header.stamp = stamp;
    msg->header.frame_id = "camera_color_left";
    msg->image_width = kWidth;
    msg->image_height = kHeight;
    // Car: h = 80 → band v ∈ (280, 320), u ∈ (100, 200).
    msg->detections.push_back(makeBox(2, "car", 0.9F, 100.F, 220.F, 200.F, 300.F));
    // Van: h = 100 → band v ∈ (285, 335), u ∈ (400, 500).
    msg->detections.push_back(makeBox(7, "van", 0.6F, 400.F, 210.F, 500.F, 310.F));
    // Truck: h = 40 → band v ∈ (90, 110), no points there.
    msg->detections.push_back(makeBox(8, "truck", 0.5F, 250.F, 60.F, 350.F, 100.F));
    return msg;
  }

  ProjectedGrid::Ptr makeGrid(const ros::Time& stamp) const
  {
    auto grid = boost::make_shared<ProjectedGrid>();
    grid->header.stamp = stamp;
    grid->header.frame_id = "camera_color_left";
    grid->grid_stamp = stamp - ros::Duration(0.03);
    grid->grid_frame_id = "world";
    grid->image_width = kWidth;
    grid->image_height = kHeight;
    // Car region: 3 dynamic + 1 static. Position median over 4: x (20 21 22 30) → 21.5,
    // y (1 2 3 4) → 2.5; velocity over the dynamic: vx (4 5 6) → 5, vy (1 2 3) → 2.
    addPoint(*grid, 120.F, 290.F, 20.F, 1.F, 4.F, 1.F, ProjectedGrid::DYNAMIC);
    addPoint(*grid, 150.F, 300.F, 21.F, 2.F, 6.F, 3.F, ProjectedGrid::DYNAMIC);
    addPoint(*grid, 180.F, 310.F, 22.F, 3.F, 5.F, 2.F, ProjectedGrid::DYNAMIC);
    addPoint(*grid, 160.F, 285.F, 30.F, 4.F, 0.F, 0.F, ProjectedGrid::STATIC);
    // Van region: 2 static, x (12, 13) → 12.5, y (−4, −2) → −3.
    addPoint(*grid, 420.F, 300.F, 12.F, -4.F, 0.F, 0.F, ProjectedGrid::STATIC);
    addPoint(*grid, 480.F, 320.F, 13.F, -2.F, 0.F, 0.F, ProjectedGrid::STATIC);
    // Outside every band.
    addPoint(*grid, 300.F, 400.F, 8.F, 0.F, 0.F, 0.F, ProjectedGrid::STATIC);
    return grid;
  }

  ros::NodeHandle nh_;
  ros::Publisher pub_detections_, pub_grid_, pub_image_;
  ros::Subscriber sub_objects_;
  std::vector<DetectedObjectArray::ConstPtr> received_;
};

TEST_F(FusionNodeletTest, BadParameterLeavesTheNodeletInactive)
{
  // The good instance advertised /objects (SetUp); the one with band_above = -1 in /bad must not
  // advertise anything, and the manager they share must keep serving the good one.
  ros::WallDuration(1.0).sleep();
  ros::master::V_TopicInfo topics;
  ASSERT_TRUE(ros::master::getTopics(topics));
  for (const auto& t : topics)
  {
    EXPECT_NE(t.name.rfind("/bad/", 0), 0U) << "the misconfigured nodelet advertised " << t.name;
  }
  subscribeObjects();
  const ros::Time stamp(1317000030, 0);
  pub_detections_.publish(makeDetections(stamp));
  pub_grid_.publish(makeGrid(stamp));
  EXPECT_TRUE(waitFor([this] { return !received_.empty(); }, 10.0)) << "the manager stopped serving";
}

TEST_F(FusionNodeletTest, AMisspeltParameterIsReportedWithTheNearestValidOne)
{
  std::vector<std::string> warnings;
  ros::Subscriber rosout = nh_.subscribe<rosgraph_msgs::Log>("/rosout", 100,
                                                             [&](const rosgraph_msgs::Log::ConstPtr& m)
                                                             {
                                                               if (m->level == rosgraph_msgs::Log::WARN)
                                                               {
                                                                 warnings.push_back(m->msg);
                                                               }
                                                             });
  // The manager is one of the /rosout publishers; give the connections a moment before it logs.
  ASSERT_TRUE(waitFor([&] { return rosout.getNumPublishers() > 1; }, 10.0)) << "no publisher on /rosout";
  waitFor([] { return false; }, 1.5);
  ros::param::set("/misspelt/fusion/band_abvoe", 0.3);
  nodelet::NodeletLoad load;
  load.request.name = "/misspelt/fusion";
  load.request.type = "grid_vision_fusion/fusion";
  ASSERT_TRUE(ros::service::call("/manager/load_nodelet", load)) << "the manager refused to load the nodelet";
  EXPECT_TRUE(load.response.success);
  auto reported = [&]
  {
    return std::any_of(warnings.begin(), warnings.end(),
                       [](const std::string& w)
                       {
                         return w.find("/misspelt/fusion/band_abvoe") != std::string::npos &&
                                w.find("did you mean band_above?") != std::string::npos;
                       });
  };
  EXPECT_TRUE(waitFor(reported, 10.0))
      << "no warning naming the misspelt parameter and the nearest valid one";
}

TEST_F(FusionNodeletTest, LazyWhileNobodyListens)
{
  ros::WallDuration(0.5).sleep();
  ros::spinOnce();
  EXPECT_EQ(pub_detections_.getNumSubscribers(), 0U);
  EXPECT_EQ(pub_grid_.getNumSubscribers(), 0U);
  EXPECT_EQ(pub_image_.getNumSubscribers(), 0U);
  subscribeObjects();
  EXPECT_EQ(pub_image_.getNumSubscribers(), 0U) << "image subscribed without an overlay subscriber";
  sub_objects_.shutdown();
  EXPECT_TRUE(waitFor(
      [this] { return pub_detections_.getNumSubscribers() == 0 && pub_grid_.getNumSubscribers() == 0; },
      10.0))
      << "inputs still subscribed after the last output subscriber left";
}

TEST_F(FusionNodeletTest, ObjectsCarryEveryField)
{
  subscribeObjects();
  const ros::Time stamp(1317000000, 123456789);
  pub_detections_.publish(makeDetections(stamp));
  pub_grid_.publish(makeGrid(stamp));
  ASSERT_TRUE(waitFor([this] { return !received_.empty(); }, 10.0)) << "no objects published";
  const DetectedObjectArray& msg = *received_.front();
  EXPECT_EQ(msg.header.stamp, stamp);
  EXPECT_EQ(msg.header.frame_id, "world");
  EXPECT_EQ(msg.image_frame_id, "camera_color_left");
  ASSERT_EQ(msg.objects.size(), 2U) << "the truck's empty region must be discarded";

  const DetectedObject& car = msg.objects[0];
  EXPECT_EQ(car.id, 0U);
  EXPECT_EQ(car.class_id, 2U);
  EXPECT_EQ(car.label, "car");
  EXPECT_FLOAT_EQ(car.score, 0.9F);
  EXPECT_EQ(car.motion, DetectedObject::MOTION_DYNAMIC);
  EXPECT_EQ(car.static_points, 1U);
  EXPECT_EQ(car.dynamic_points, 3U);
  EXPECT_DOUBLE_EQ(car.position.x, 21.5);
  EXPECT_DOUBLE_EQ(car.position.y, 2.5);
  EXPECT_DOUBLE_EQ(car.position.z, 0.0);
  EXPECT_DOUBLE_EQ(car.velocity.x, 5.0);
  EXPECT_DOUBLE_EQ(car.velocity.y, 2.0);
  EXPECT_DOUBLE_EQ(car.velocity.z, 0.0);
  EXPECT_NEAR(car.heading, std::atan2(2.0, 5.0), 1e-6);
  EXPECT_FLOAT_EQ(car.x_min, 100.F);
  EXPECT_FLOAT_EQ(car.y_min, 220.F);
  EXPECT_FLOAT_EQ(car.x_max, 200.F);
  EXPECT_FLOAT_EQ(car.y_max, 300.F);

  const DetectedObject& van = msg.objects[1];
  EXPECT_EQ(van.id, 1U);
  EXPECT_EQ(van.class_id, 7U);
  EXPECT_EQ(van.label, "van");
  EXPECT_FLOAT_EQ(van.score, 0.6F);
  EXPECT_EQ(van.motion, DetectedObject::MOTION_STATIC);
  EXPECT_EQ(van.static_points, 2U);
  EXPECT_EQ(van.dynamic_points, 0U);
  EXPECT_DOUBLE_EQ(van.position.x, 12.5);
  EXPECT_DOUBLE_EQ(van.position.y, -3.0);
  EXPECT_DOUBLE_EQ(van.velocity.x, 0.0);
  EXPECT_DOUBLE_EQ(van.velocity.y, 0.0);
  EXPECT_FLOAT_EQ(van.heading, 0.F);
  EXPECT_FLOAT_EQ(van.x_min, 400.F);
  EXPECT_FLOAT_EQ(van.y_max, 310.F);
}

TEST_F(FusionNodeletTest, TrackedObjectsKeepTheirIdsAndTheMarkersShowThem)
{
  // The instance under /tracked runs the defaults: the car and the van are published from the
  // first image, as tentative tracks, then confirmed, with track ids that stay.
  ros::Publisher detections = nh_.advertise<Detection2DArray>("/tracked/detections", 10);
  ros::Publisher grids = nh_.advertise<ProjectedGrid>("/tracked/projected_grid", 10);
  std::vector<DetectedObjectArray::ConstPtr> objects;
  std::vector<visualization_msgs::MarkerArray::ConstPtr> markers;
  ros::Subscriber sub_objects = nh_.subscribe<DetectedObjectArray>(
      "/tracked/objects", 10, [&](const DetectedObjectArray::ConstPtr& m) { objects.push_back(m); });
  ros::Subscriber sub_markers = nh_.subscribe<visualization_msgs::MarkerArray>(
      "/tracked/objects/markers", 10,
      [&](const visualization_msgs::MarkerArray::ConstPtr& m) { markers.push_back(m); });
  ASSERT_TRUE(
      waitFor([&] { return detections.getNumSubscribers() > 0 && grids.getNumSubscribers() > 0; }, 20.0))
      << "the tracked fusion nodelet did not subscribe its inputs";
  for (int k = 0; k < 4; ++k)
  {
    const ros::Time stamp = ros::Time(1317000100, 0) + ros::Duration(0.1 * k);
    detections.publish(makeDetections(stamp));
    grids.publish(makeGrid(stamp));
    ASSERT_TRUE(waitFor([&] { return objects.size() > static_cast<std::size_t>(k); }, 10.0)) << "image " << k;
  }
  ASSERT_EQ(objects[0]->objects.size(), 2U) << "no detected object is withheld";
  const std::uint32_t car = objects[0]->objects[0].id;
  const std::uint32_t van = objects[0]->objects[1].id;
  EXPECT_GE(car, 1U);
  EXPECT_NE(car, van);
  for (std::size_t k = 0; k < objects.size(); ++k)
  {
    ASSERT_EQ(objects[k]->objects.size(), 2U);
    EXPECT_EQ(objects[k]->objects[0].id, car);
    EXPECT_EQ(objects[k]->objects[1].id, van);
    const std::uint8_t state = k == 0 ? DetectedObject::TRACK_TENTATIVE : DetectedObject::TRACK_CONFIRMED;
    EXPECT_EQ(objects[k]->objects[0].track_state, state) << "image " << k;
    EXPECT_EQ(objects[k]->objects[1].track_state, state) << "image " << k;
  }
  ASSERT_TRUE(waitFor([&] { return markers.size() >= 4; }, 10.0)) << "no markers";
  bool labelled = false;
  for (const auto& marker : markers.back()->markers)
  {
    labelled = labelled || marker.text.rfind("#" + std::to_string(car) + " ", 0) == 0;
  }
  EXPECT_TRUE(labelled) << "no marker label starts with the car's track id";
}

TEST_F(FusionNodeletTest, EmptyInputStillPublishes)
{
  subscribeObjects();
  const ros::Time stamp(1317000001, 0);
  auto detections = makeDetections(stamp);
  detections->detections.clear();
  pub_detections_.publish(detections);
  pub_grid_.publish(makeGrid(stamp));
  ASSERT_TRUE(waitFor([this] { return !received_.empty(); }, 10.0)) << "silence for an image without boxes";
  EXPECT_EQ(received_.front()->header.stamp, stamp);
  EXPECT_TRUE(received_.front()->objects.empty());

  const ros::Time stamp2(1317000002, 0);
  auto grid = makeGrid(stamp2);
  grid->u.clear();
  grid->v.clear();
  grid->depth.clear();
  grid->x.clear();
  grid->y.clear();
  grid->vx.clear();
  grid->vy.clear();
  grid->p_static.clear();
  grid->p_dynamic.clear();
  grid->state.clear();
  pub_detections_.publish(makeDetections(stamp2));
  pub_grid_.publish(grid);
  ASSERT_TRUE(waitFor([this] { return received_.size() >= 2; }, 10.0))
      << "silence for an image without points";
  EXPECT_EQ(received_[1]->header.stamp, stamp2);
  EXPECT_TRUE(received_[1]->objects.empty());
}

TEST_F(FusionNodeletTest, MalformedInputGivesNoOutputAndNoCrash)
{
  subscribeObjects();
  // Arrays of different lengths.
  const ros::Time bad_lengths(1317000010, 0);
  auto grid = makeGrid(bad_lengths);
  grid->vx.pop_back();
  pub_detections_.publish(makeDetections(bad_lengths));
  pub_grid_.publish(grid);
  // Image sizes differ between the inputs.
  const ros::Time bad_size(1317000011, 0);
  auto small_grid = makeGrid(bad_size);
  small_grid->image_width = 320;
  pub_detections_.publish(makeDetections(bad_size));
  pub_grid_.publish(small_grid);
  // A box with x_min > x_max, and a NaN box.
  const ros::Time bad_box(1317000012, 0);
  auto swapped = makeDetections(bad_box);
  std::swap(swapped->detections[0].x_min, swapped->detections[0].x_max);
  pub_detections_.publish(swapped);
  pub_grid_.publish(makeGrid(bad_box));
  const ros::Time nan_box(1317000013, 0);
  auto nan_detections = makeDetections(nan_box);
  nan_detections->detections[1].y_max = std::nanf("");
  pub_detections_.publish(nan_detections);
  pub_grid_.publish(makeGrid(nan_box));
  // A box outside the image.
  const ros::Time outside(1317000014, 0);
  auto outside_detections = makeDetections(outside);
  outside_detections->detections[1].x_max = 900.F;
  pub_detections_.publish(outside_detections);
  pub_grid_.publish(makeGrid(outside));

  EXPECT_FALSE(waitFor([this] { return !received_.empty(); }, 1.5)) << "malformed input produced output";

  // The nodelet is still alive and answers a good pair.
  const ros::Time good(1317000015, 0);
  pub_detections_.publish(makeDetections(good));
  pub_grid_.publish(makeGrid(good));
  ASSERT_TRUE(waitFor([this] { return !received_.empty(); }, 10.0)) << "no output after malformed input";
  EXPECT_EQ(received_.front()->header.stamp, good);
  EXPECT_EQ(received_.front()->objects.size(), 2U);
}

TEST_F(FusionNodeletTest, MarkersAndOverlay)
{
  std::vector<visualization_msgs::MarkerArray::ConstPtr> markers;
  std::vector<sensor_msgs::Image::ConstPtr> overlays;
  ros::Subscriber sub_markers = nh_.subscribe<visualization_msgs::MarkerArray>(
      "objects/markers", 10,
      [&](const visualization_msgs::MarkerArray::ConstPtr& m) { markers.push_back(m); });
  ros::Subscriber sub_overlay = nh_.subscribe<sensor_msgs::Image>(
      "objects/image", 10, [&](const sensor_msgs::Image::ConstPtr& m) { overlays.push_back(m); });
  ASSERT_TRUE(waitFor(
      [this] { return pub_image_.getNumSubscribers() > 0 && pub_detections_.getNumSubscribers() > 0; }, 10.0))
      << "an overlay subscriber must make the nodelet subscribe the image";

  const ros::Time stamp(1317000020, 500);
  auto image = boost::make_shared<sensor_msgs::Image>();
  image->header.stamp = stamp;
  image->header.frame_id = "camera_color_left";
  image->width = kWidth;
  image->height = kHeight;
  image->encoding = sensor_msgs::image_encodings::RGB8;
  image->step = kWidth * 3;
  image->data.assign(image->step * kHeight, 0);
  pub_image_.publish(image);
  ros::WallDuration(0.2).sleep();  // the image arrives before the detections, as with a detector
  pub_detections_.publish(makeDetections(stamp));
  pub_grid_.publish(makeGrid(stamp));

  ASSERT_TRUE(waitFor([&] { return !markers.empty() && !overlays.empty(); }, 10.0));
  const auto& m = markers.front()->markers;
  // DELETEALL; car: cylinder, arrow, text; van: cylinder, text.
  ASSERT_EQ(m.size(), 6U);
  EXPECT_EQ(m[0].action, visualization_msgs::Marker::DELETEALL);
  EXPECT_EQ(m[3].text, "dynamic car 5.4 m/s");  // |(5, 2)| = 5.39
  EXPECT_EQ(m[5].text, "static van");
  for (std::size_t i = 1; i < m.size(); ++i)
  {
    EXPECT_EQ(m[i].header.frame_id, "world");
    EXPECT_EQ(m[i].header.stamp, stamp);
  }

  const sensor_msgs::Image& overlay = *overlays.front();
  EXPECT_EQ(overlay.header.stamp, stamp);
  EXPECT_EQ(overlay.encoding, sensor_msgs::image_encodings::BGR8);
  ASSERT_EQ(overlay.width, kWidth);
  ASSERT_EQ(overlay.height, kHeight);
  auto pixel = [&](int u, int v)
  {
    const std::size_t i = static_cast<std::size_t>(v) * overlay.step + static_cast<std::size_t>(u) * 3;
    return std::array<int, 3>{overlay.data[i], overlay.data[i + 1], overlay.data[i + 2]};
  };
  EXPECT_EQ(pixel(100, 260), (std::array<int, 3>{0, 200, 0}));  // dynamic car box edge: green
  EXPECT_EQ(pixel(400, 260), (std::array<int, 3>{255, 0, 0}));  // static van box edge: blue
}

}  // namespace
}  // namespace grid_vision_fusion

int main(int argc, char** argv)
{
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_fusion_nodelet");
  ros::NodeHandle nh;
  return RUN_ALL_TESTS();
}
