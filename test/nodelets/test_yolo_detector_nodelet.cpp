// rostest: the yolo_detector nodelet with the tiny Darknet model (known output) in a nodelet
// manager: the published detection, header and image size, the empty array, laziness, the
// overlay, diagnostics, a bad encoding, and a nodelet with a missing model that stays silent
// while the manager keeps running.
#include <gtest/gtest.h>

#include <diagnostic_msgs/DiagnosticArray.h>
#include <nodelet/NodeletLoad.h>
#include <nodelet/NodeletUnload.h>
#include <ros/ros.h>
#include <sensor_msgs/Image.h>
#include <sensor_msgs/image_encodings.h>

#include <filesystem>
#include <functional>

#include "../detection/tiny_darknet.h"
#include "grid_vision_fusion/Detection2DArray.h"
#include "wait_for.h"

namespace grid_vision_fusion
{
namespace
{
using test::waitFor;
std::string g_model_dir;

bool loadNodelet(const std::string& name, const std::string& prefix)
{
  nodelet::NodeletLoad load;
  load.request.name = name;
  load.request.type = "grid_vision_fusion/yolo_detector";
  load.request.remap_source_args = {"image", "detections", "detections/image"};
  load.request.remap_target_args = {prefix + "/image", prefix + "/detections", prefix + "/detections/image"};
  if (!ros::service::waitForService("/manager/load_nodelet", ros::Duration(20.0)))
  {
    return false;
  }
  return ros::service::call("/manager/load_nodelet", load) && load.response.success;
}

/// A 64 × 32 image of encoding `encoding` (rgb8 or bgr8), black but for a red 4×4 block at
/// x ∈ [20, 24), y ∈ [8, 12).
sensor_msgs::Image::Ptr redBlockImage(const std::string& encoding, const ros::Time& stamp,
                                      bool with_block = true)
{
  auto image = boost::make_shared<sensor_msgs::Image>();
  image->header.stamp = stamp;
  image->header.frame_id = "camera_color_left";
  image->width = 64;
  image->height = 32;
  image->encoding = encoding;
  image->step = 64 * 3;
  image->data.assign(image->step * image->height, 0);
  const std::size_t red = encoding == sensor_msgs::image_encodings::RGB8 ? 0 : 2;
  for (int y = 8; with_block && y < 12; ++y)
  {
    for (int x = 20; x < 24; ++x)
    {
      image->data[static_cast<std::size_t>(y) * image->step + static_cast<std::size_t>(x) * 3 + red] = 255;
    }
  }
  return image;
}

class YoloDetectorNodeletTest : public ::testing::Test
{
protected:
  void SetUp() override
  {
    pub_image_ = nh_.advertise<sensor_msgs::Image>("/tiny/image", 10);
    sub_diagnostics_ = nh_.subscribe<diagnostic_msgs::DiagnosticArray>(
        "/diagnostics", 50,
        [this](const diagnostic_msgs::DiagnosticArray::ConstPtr& m) { diagnostics_.push_back(m); });
  }

  void subscribeDetections()
  {
    sub_detections_ = nh_.subscribe<Detection2DArray>(
        "/tiny/detections", 10, [this](const Detection2DArray::ConstPtr& msg) { received_.push_back(msg); });
    ASSERT_TRUE(waitFor([this] { return pub_image_.getNumSubscribers() > 0; }, 10.0))
        << "the nodelet did not subscribe the image";
  }

  ros::NodeHandle nh_;
  ros::Publisher pub_image_;
  ros::Subscriber sub_detections_, sub_diagnostics_;
  std::vector<Detection2DArray::ConstPtr> received_;
  std::vector<diagnostic_msgs::DiagnosticArray::ConstPtr> diagnostics_;
};

TEST_F(YoloDetectorNodeletTest, LazyWhileNobodyListens)
{
  ros::WallDuration(0.5).sleep();
  EXPECT_EQ(pub_image_.getNumSubscribers(), 0U);
  subscribeDetections();
  sub_detections_.shutdown();
  EXPECT_TRUE(waitFor([this] { return pub_image_.getNumSubscribers() == 0; }, 10.0))
      << "image still subscribed after the last subscriber left";
}

TEST_F(YoloDetectorNodeletTest, PublishesTheConstructedBoxInImagePixels)
{
  subscribeDetections();
  const ros::Time stamp(1317000000, 250000000);
  pub_image_.publish(redBlockImage(sensor_msgs::image_encodings::RGB8, stamp));
  ASSERT_TRUE(waitFor([this] { return !received_.empty(); }, 10.0)) << "no detections published";
  const Detection2DArray& msg = *received_.front();
  EXPECT_EQ(msg.header.stamp, stamp) << "header must be the image's";
  EXPECT_EQ(msg.header.frame_id, "camera_color_left");
  EXPECT_EQ(msg.image_width, 64U);
  EXPECT_EQ(msg.image_height, 32U);
  ASSERT_EQ(msg.detections.size(), 1U);
  const Detection2D& d = msg.detections[0];
  EXPECT_EQ(d.class_id, 0U);
  EXPECT_EQ(d.label, "car");
  // Full red: objectness and class logits 10 → σ(10)².
  EXPECT_NEAR(d.score, test::sigmoid(10.0) * test::sigmoid(10.0), 1e-4);
  // Letterbox 64×32 → 16×16 (scale 1/4, 4 grey rows on top): network cell (5, 6), anchor 4×2.
  EXPECT_NEAR(d.x_min, 14.0, 1e-3);
  EXPECT_NEAR(d.y_min, 6.0, 1e-3);
  EXPECT_NEAR(d.x_max, 30.0, 1e-3);
  EXPECT_NEAR(d.y_max, 14.0, 1e-3);

  // The same picture in bgr8 gives the same box.
  pub_image_.publish(redBlockImage(sensor_msgs::image_encodings::BGR8, stamp + ros::Duration(0.1)));
  ASSERT_TRUE(waitFor([this] { return received_.size() >= 2; }, 10.0));
  ASSERT_EQ(received_[1]->detections.size(), 1U);
  EXPECT_EQ(received_[1]->detections[0].label, "car");
}

TEST_F(YoloDetectorNodeletTest, EmptyArrayForAnEmptyScene)
{
  subscribeDetections();
  const ros::Time stamp(1317000001, 0);
  pub_image_.publish(redBlockImage(sensor_msgs::image_encodings::BGR8, stamp, false));
  ASSERT_TRUE(waitFor([this] { return !received_.empty(); }, 10.0)) << "silence for an image without objects";
  EXPECT_EQ(received_.front()->header.stamp, stamp);
  EXPECT_TRUE(received_.front()->detections.empty());
}

TEST_F(YoloDetectorNodeletTest, UnsupportedEncodingIsSkippedAndCounted)
{
  subscribeDetections();
  auto depth = boost::make_shared<sensor_msgs::Image>();
  depth->header.stamp = ros::Time(1317000002, 0);
  depth->width = 8;
  depth->height = 8;
  depth->encoding = sensor_msgs::image_encodings::TYPE_16UC1;
  depth->step = 16;
  depth->data.assign(128, 0);
  pub_image_.publish(depth);
  EXPECT_FALSE(waitFor([this] { return !received_.empty(); }, 1.0)) << "output for a 16UC1 image";
  const ros::Time good(1317000003, 0);
  pub_image_.publish(redBlockImage(sensor_msgs::image_encodings::RGB8, good));
  ASSERT_TRUE(waitFor([this] { return !received_.empty(); }, 10.0)) << "no output after a bad image";
  EXPECT_EQ(received_.front()->header.stamp, good);

  // Diagnostics count the frames and report the inference time.
  auto find_status = [this]() -> const diagnostic_msgs::DiagnosticStatus*
  {
    for (auto it = diagnostics_.rbegin(); it != diagnostics_.rend(); ++it)
    {
      for (const auto& status : (*it)->status)
      {
        bool failed = false;
        for (const auto& kv : status.values)
        {
          failed = failed || (kv.key == "frames failed" && kv.value != "0");
        }
        if (status.name.find("yolo_detector") != std::string::npos && failed)
        {
          return &status;
        }
      }
    }
    return nullptr;
  };
  ASSERT_TRUE(waitFor([&] { return find_status() != nullptr; }, 5.0))
      << "no diagnostics with the failed frame";
  const diagnostic_msgs::DiagnosticStatus& status = *find_status();
  std::map<std::string, std::string> values;
  for (const auto& kv : status.values)
  {
    values[kv.key] = kv.value;
  }
  EXPECT_EQ(values.count("frames dropped"), 1U);
  EXPECT_EQ(values.count("mean inference time [ms]"), 1U);
  EXPECT_EQ(values["frames failed"], "1");
}

TEST_F(YoloDetectorNodeletTest, OverlayShowsTheBox)
{
  std::vector<sensor_msgs::Image::ConstPtr> overlays;
  ros::Subscriber sub = nh_.subscribe<sensor_msgs::Image>(
      "/tiny/detections/image", 5, [&](const sensor_msgs::Image::ConstPtr& m) { overlays.push_back(m); });
  ASSERT_TRUE(waitFor([this] { return pub_image_.getNumSubscribers() > 0; }, 10.0))
      << "an overlay subscriber alone must make the nodelet subscribe the image";
  const ros::Time stamp(1317000004, 0);
  pub_image_.publish(redBlockImage(sensor_msgs::image_encodings::RGB8, stamp));
  ASSERT_TRUE(waitFor([&] { return !overlays.empty(); }, 10.0)) << "no overlay";
  const sensor_msgs::Image& overlay = *overlays.front();
  EXPECT_EQ(overlay.header.stamp, stamp);
  EXPECT_EQ(overlay.encoding, sensor_msgs::image_encodings::BGR8);
  ASSERT_EQ(overlay.width, 64U);
  // The bottom edge of box (14, 6)–(30, 14) is drawn in the class-0 colour (BGR 0, 200, 255).
  const std::size_t i = 14 * overlay.step + 22 * 3;
  EXPECT_EQ(overlay.data[i], 0);
  EXPECT_EQ(overlay.data[i + 1], 200);
  EXPECT_EQ(overlay.data[i + 2], 255);
}

TEST_F(YoloDetectorNodeletTest, MissingModelLeavesTheManagerRunning)
{
  ros::param::set("/broken_detector/model", g_model_dir + "/absent.cfg");
  ros::param::set("/broken_detector/weights", g_model_dir + "/tiny.weights");
  ros::param::set("/broken_detector/class_names", g_model_dir + "/tiny.names");
  // The load fails (its loader exits, which ends a launch that requires it) ...
  EXPECT_FALSE(loadNodelet("/broken_detector", "/broken")) << "a nodelet without its model was loaded";
  ros::Publisher pub = nh_.advertise<sensor_msgs::Image>("/broken/image", 1);
  ros::Subscriber sub = nh_.subscribe<Detection2DArray>(
      "/broken/detections", 1, [this](const Detection2DArray::ConstPtr& m) { received_.push_back(m); });
  EXPECT_FALSE(waitFor([&] { return pub.getNumSubscribers() > 0 || sub.getNumPublishers() > 0; }, 1.5))
      << "a nodelet without its model must not run";
  // The manager and the working nodelet still answer.
  subscribeDetections();
  pub_image_.publish(redBlockImage(sensor_msgs::image_encodings::RGB8, ros::Time(1317000005, 0)));
  EXPECT_TRUE(waitFor([this] { return !received_.empty(); }, 10.0));
}

}  // namespace
}  // namespace grid_vision_fusion

int main(int argc, char** argv)
{
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_yolo_detector_nodelet");
  ros::NodeHandle nh;
  using namespace grid_vision_fusion;
  g_model_dir = test::makeTempDirectory();
  const test::TinyDarknetFiles files = test::writeTinyDarknet(g_model_dir, test::TinyDarknetSpec());
  ros::param::set("/yolo_detector/model", files.cfg);
  ros::param::set("/yolo_detector/weights", files.weights);
  ros::param::set("/yolo_detector/class_names", files.names);
  ros::param::set("/yolo_detector/score_threshold", 0.6);  // above the grey border's 0.5
  ros::param::set("/yolo_detector/nms_threshold", 0.45);
  if (!loadNodelet("/yolo_detector", "/tiny"))
  {
    ADD_FAILURE() << "cannot load the yolo_detector nodelet into /manager";
  }
  const int result = RUN_ALL_TESTS();
  std::filesystem::remove_all(g_model_dir);
  return result;
}
