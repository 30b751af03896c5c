// Runs the bag_summary tool on a bag written by the test and checks what it prints and writes.
#include <gtest/gtest.h>

#include <rosbag/bag.h>
#include <sensor_msgs/Image.h>
#include <sensor_msgs/image_encodings.h>

#include <cstdio>
#include <filesystem>
#include <memory>

#include "grid_vision_fusion/DetectedObjectArray.h"

namespace grid_vision_fusion
{
namespace
{
namespace fs = std::filesystem;

DetectedObject object(std::uint32_t id, const std::string& label, std::uint8_t motion, double vx)
{
  DetectedObject o;
  o.id = id;
  o.label = label;
  o.motion = motion;
  o.velocity.x = vx;
  return o;
}

std::string run(const std::string& command, int& status)
{
  std::string output;
  std::unique_ptr<FILE, int (*)(FILE*)> pipe(popen((command + " 2>&1").c_str(), "r"), pclose);
  char buffer[512];
  while (std::fgets(buffer, sizeof(buffer), pipe.get()))
  {
    output += buffer;
  }
  status = pclose(pipe.release());
  return output;
}
}  // namespace

TEST(BagSummary, CountsAndExportsFrames)
{
  const fs::path dir = fs::path(testing::TempDir()) / "bag_summary";
  fs::remove_all(dir);
  fs::create_directories(dir);
  const std::string bag_path = (dir / "objects.bag").string();
  {
    rosbag::Bag bag(bag_path, rosbag::bagmode::Write);
    for (int frame = 0; frame < 3; ++frame)
    {
      const ros::Time stamp(100 + frame, 0);
      DetectedObjectArray objects;
      objects.header.stamp = stamp;
      objects.objects.push_back(object(3, "car", DetectedObject::MOTION_DYNAMIC, 4.0));
      if (frame > 0)  // track 4: static, then dynamic at 2 m/s
      {
        objects.objects.push_back(object(
            4, "car", frame == 1 ? DetectedObject::MOTION_STATIC : DetectedObject::MOTION_DYNAMIC, 2.0));
      }
      if (frame == 2)
      {
        objects.objects.push_back(object(5, "van", DetectedObject::MOTION_UNKNOWN, 0.0));
      }
      bag.write("/objects", stamp, objects);
      sensor_msgs::Image image;
      image.header.stamp = stamp;
      image.width = 32;
      image.height = 16;
      image.encoding = sensor_msgs::image_encodings::BGR8;
      image.step = 96;
      image.data.assign(96 * 16, static_cast<std::uint8_t>(40 * frame));
      bag.write("/objects/image", stamp, image);
    }
  }
  int status = 0;
  const std::string output = run(std::string(BAG_SUMMARY) + " --bag " + bag_path + " --frames-dir " +
                                     (dir / "frames").string() + " --video " + (dir / "overlay.avi").string(),
                                 status);
  ASSERT_EQ(status, 0) << output;
  EXPECT_NE(output.find("3 frames of /objects, 3 overlay images"), std::string::npos) << output;
  EXPECT_NE(output.find("1 object(s): 1 frame(s)"), std::string::npos) << output;
  EXPECT_NE(output.find("2 object(s): 1 frame(s)"), std::string::npos) << output;
  EXPECT_NE(output.find("3 object(s): 1 frame(s)"), std::string::npos) << output;
  // car: 1 static, 4 dynamic at (4 + 4 + 4 + 2) / 4 = 3.5 m/s; van: 1 unknown.
  EXPECT_NE(output.find("car                 1        4        0  3.500"), std::string::npos) << output;
  EXPECT_NE(output.find("van                 0        0        1  -"), std::string::npos) << output;
  // Tracks: 3 (car, frames 0-2, dynamic), 4 (car, frames 1-2, one change), 5 (van, frame 2).
  EXPECT_NE(output.find("3 tracks (objects by id"), std::string::npos) << output;
  EXPECT_NE(
      output.find(
          "3        car               3    100.000      102.000        0        3        0        0  4.000"),
      std::string::npos)
      << output;
  EXPECT_NE(
      output.find(
          "4        car               2    101.000      102.000        1        1        0        1  2.000"),
      std::string::npos)
      << output;
  EXPECT_NE(
      output.find(
          "5        van               1    102.000      102.000        0        0        1        0  -"),
      std::string::npos)
      << output;
  EXPECT_TRUE(fs::exists(dir / "frames" / "000002.png"));
  EXPECT_GT(fs::file_size(dir / "overlay.avi"), 0U);

  const std::string missing = run(std::string(BAG_SUMMARY) + " --bag " + (dir / "none.bag").string(), status);
  EXPECT_NE(status, 0);
  EXPECT_NE(missing.find("none.bag"), std::string::npos) << missing;
}

}  // namespace grid_vision_fusion
