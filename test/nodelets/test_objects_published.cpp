// rostest node: the chain that its .test file launches publishes object arrays on /objects, at
// least ~min_arrays of them, from a detector configured as the test says (kitti_replay_onnx.test:
// the fetched YOLOv5s ONNX model given as model:= alone). Skipped, naming the command that fetches
// it, when ~have_model is false.
#include <gtest/gtest.h>

#include <ros/ros.h>

#include <atomic>
#include <string>

#include "grid_vision_fusion/DetectedObjectArray.h"
#include "wait_for.h"

namespace grid_vision_fusion
{
namespace
{
TEST(ObjectsPublished, TheLaunchPublishesObjectArrays)
{
  ros::NodeHandle nh;
  ros::NodeHandle pnh("~");
  const std::string model = pnh.param<std::string>("model", "");
  if (!pnh.param("have_model", false))
  {
    GTEST_SKIP() << model << " is not there: fetch it with scripts/fetch_model.sh yolov5s";
  }
  const int min_arrays = pnh.param("min_arrays", 5);
  std::atomic<int> arrays{0};
  std::atomic<std::size_t> objects{0};
  ros::Subscriber sub = nh.subscribe<DetectedObjectArray>("/objects", 100,
                                                          [&](const DetectedObjectArray::ConstPtr& m)
                                                          {
                                                            ++arrays;
                                                            objects += m->objects.size();
                                                          });
  EXPECT_TRUE(test::waitFor([&] { return arrays >= min_arrays; }, pnh.param("timeout", 100.0)))
      << "only " << arrays << " object arrays on /objects from the chain with the model " << model;
  RecordProperty("object_arrays", arrays);
  RecordProperty("objects", static_cast<int>(objects));
}

}  // namespace
}  // namespace grid_vision_fusion

int main(int argc, char** argv)
{
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_objects_published");
  return RUN_ALL_TESTS();
}
