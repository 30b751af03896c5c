// rostest: the yolo_detector nodelet with the replay backend's detector noise on publishes, for
// each image, the detections that DetectionReplay draws for that image's frame index from the
// nodelet's own parameters: the nodelet and run_pipeline (the same DetectorStage, the same frame
// indices) give the same noisy detections.
#include <gtest/gtest.h>

#include <ros/ros.h>
#include <sensor_msgs/Image.h>
#include <sensor_msgs/image_encodings.h>

#include "grid_vision_fusion/Detection2DArray.h"
#include "grid_vision_fusion/detection/detection_replay.h"
#include "grid_vision_fusion/ros/node_params.h"
#include "wait_for.h"

namespace grid_vision_fusion
{
namespace
{
using test::waitFor;

TEST(YoloReplayNoiseNodeletTest, PublishesTheNoiseOfEachFrameIndex)
{
  ros::NodeHandle nh;
  const ros::NodeHandle detector_nh("/yolo_detector");
  const DetectorParams params = DetectorParams::fromParams(NodeHandleParamSource(detector_nh));
  ASSERT_TRUE(params.replay.noise.enabled);
  ASSERT_EQ(params.replay.noise.seed, 5U);
  DetectionReplay library(params.replay);

  std::vector<Detection2DArray::ConstPtr> received;
  ros::Publisher pub = nh.advertise<sensor_msgs::Image>("image", 10);
  ros::Subscriber sub = nh.subscribe<Detection2DArray>(
      "detections", 10, [&](const Detection2DArray::ConstPtr& m) { received.push_back(m); });
  ASSERT_TRUE(waitFor([&] { return pub.getNumSubscribers() > 0; }, 20.0))
      << "the nodelet never subscribed image";
  for (int k = 0; k < 3; ++k)
  {
    auto image = boost::make_shared<sensor_msgs::Image>();
    image->header.stamp = ros::Time(1317000000 + k, 0);
    image->header.frame_id = "camera_color_left";
    image->width = 1242;
    image->height = 375;
    image->encoding = sensor_msgs::image_encodings::MONO8;
    image->step = 1242;
    image->data.assign(1242 * 375, 0);
    pub.publish(image);
    ASSERT_TRUE(waitFor([&] { return received.size() == static_cast<std::size_t>(k + 1); }, 10.0))
        << "no detections for frame " << k;
  }
  std::size_t compared = 0;
  for (int k = 0; k < 3; ++k)
  {
    const std::vector<Detection> expected = library.detectionsOf(k, 1242, 375);
    ASSERT_EQ(received[k]->detections.size(), expected.size()) << "frame " << k;
    for (std::size_t i = 0; i < expected.size(); ++i)
    {
      const Detection2D& d = received[k]->detections[i];
      EXPECT_EQ(d.label, expected[i].label);
      EXPECT_EQ(d.class_id, expected[i].class_id);
      EXPECT_FLOAT_EQ(d.score, expected[i].score);
      EXPECT_FLOAT_EQ(d.x_min, expected[i].box.x_min);
      EXPECT_FLOAT_EQ(d.y_min, expected[i].box.y_min);
      EXPECT_FLOAT_EQ(d.x_max, expected[i].box.x_max);
      EXPECT_FLOAT_EQ(d.y_max, expected[i].box.y_max);
      ++compared;
    }
  }
  EXPECT_GT(compared, 3U) << "with the threshold at 0.05 the noise adds boxes to the 5 labels";
}

}  // namespace
}  // namespace grid_vision_fusion

int main(int argc, char** argv)
{
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_yolo_replay_noise_nodelet");
  ros::NodeHandle nh;
  return RUN_ALL_TESTS();
}
