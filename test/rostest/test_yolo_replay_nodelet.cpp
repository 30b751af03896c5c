// rostest: the yolo_detector nodelet with the replay backend publishes the boxes of the KITTI
// label files 000000, 000001, 000002 for the first three images, mapped to the KITTI-style
// labels of config/yolo_detector.yaml, and nothing for a frame without a file.
#include <gtest/gtest.h>

#include <ros/ros.h>
#include <sensor_msgs/Image.h>
#include <sensor_msgs/image_encodings.h>

#include <functional>

#include "grid_vision_fusion/Detection2DArray.h"
#include "wait_for.h"

namespace grid_vision_fusion
{
namespace
{
using test::waitFor;

void expectBox(const Detection2D& d, const std::string& label, float x_min, float y_min, float x_max,
               float y_max)
{
  EXPECT_EQ(d.label, label);
  EXPECT_FLOAT_EQ(d.score, 1.F) << "ground truth has no score column: default_score";
  EXPECT_FLOAT_EQ(d.x_min, x_min);
  EXPECT_FLOAT_EQ(d.y_min, y_min);
  EXPECT_FLOAT_EQ(d.x_max, x_max);
  EXPECT_FLOAT_EQ(d.y_max, y_max);
}

TEST(YoloReplayNodeletTest, PublishesTheBoxesOfTheLabelFiles)
{
  ros::NodeHandle nh;
  std::vector<Detection2DArray::ConstPtr> received;
  ros::Publisher pub = nh.advertise<sensor_msgs::Image>("image", 10);
  ros::Subscriber sub = nh.subscribe<Detection2DArray>(
      "detections", 10, [&](const Detection2DArray::ConstPtr& m) { received.push_back(m); });
  ASSERT_TRUE(waitFor([&] { return pub.getNumSubscribers() > 0; }, 20.0))
      << "the nodelet never subscribed image";

  // The replay never looks at the pixels: a tiny 16UC1 image of KITTI's size in the header only
  // would do, but the detections are clipped to width × height, so give the real size.
  auto make_image = [](int k)
  {
    auto image = boost::make_shared<sensor_msgs::Image>();
    image->header.stamp = ros::Time(1317000000 + k, 0);
    image->header.frame_id = "camera_color_left";
    image->width = 1242;
    image->height = 375;
    image->encoding = sensor_msgs::image_encodings::MONO8;
    image->step = 1242;
    image->data.assign(1242 * 375, 0);
    return image;
  };
  for (int k = 0; k < 4; ++k)
  {
    pub.publish(make_image(k));
    // One at a time: the detector keeps only the newest frame when it falls behind.
    if (k < 3)
    {
      ASSERT_TRUE(waitFor([&] { return received.size() == static_cast<std::size_t>(k + 1); }, 10.0))
          << "no detections for frame " << k;
    }
  }
  EXPECT_FALSE(waitFor([&] { return received.size() > 3; }, 1.0))
      << "output for frame 3, which has no label file";
  ASSERT_EQ(received.size(), 3U);
  for (int k = 0; k < 3; ++k)
  {
    EXPECT_EQ(received[k]->header.stamp, ros::Time(1317000000 + k, 0));
    EXPECT_EQ(received[k]->header.frame_id, "camera_color_left");
    EXPECT_EQ(received[k]->image_width, 1242U);
    EXPECT_EQ(received[k]->image_height, 375U);
  }
  // 000000: one pedestrian.
  ASSERT_EQ(received[0]->detections.size(), 1U);
  expectBox(received[0]->detections[0], "pedestrian", 712.40F, 143.00F, 810.73F, 307.92F);
  // 000001: Truck, Car, Cyclist; the four DontCare are not in the class map.
  ASSERT_EQ(received[1]->detections.size(), 3U);
  expectBox(received[1]->detections[0], "truck", 599.41F, 156.40F, 629.75F, 189.25F);
  expectBox(received[1]->detections[1], "car", 387.63F, 181.54F, 423.81F, 203.12F);
  expectBox(received[1]->detections[2], "cyclist", 676.60F, 163.95F, 688.98F, 193.93F);
  EXPECT_EQ(received[1]->detections[1].class_id, 0U);
  // 000002: Misc is dropped, the car stays.
  ASSERT_EQ(received[2]->detections.size(), 1U);
  expectBox(received[2]->detections[0], "car", 657.39F, 190.13F, 700.07F, 223.39F);
}

}  // namespace
}  // namespace grid_vision_fusion

int main(int argc, char** argv)
{
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_yolo_replay_nodelet");
  ros::NodeHandle nh;
  return RUN_ALL_TESTS();
}
