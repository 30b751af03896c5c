// latency_probe (scripts/soak.sh): one CSV row per camera frame with the wall-clock latency to the
// objects of the same stamp, empty when none came; written when the probe is ended with SIGINT.
#include <gtest/gtest.h>
#include <ros/ros.h>
#include <sensor_msgs/CameraInfo.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <functional>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "grid_vision_fusion/DetectedObjectArray.h"

extern char** environ;

namespace
{
namespace fs = std::filesystem;

/// The rows of a CSV file after its header, split at the commas (an empty last field kept).
std::vector<std::vector<std::string>> csvRows(const fs::path& path)
{
  std::ifstream in(path);
  std::string line;
  std::getline(in, line);
  std::vector<std::vector<std::string>> rows;
  while (std::getline(in, line))
  {
    std::vector<std::string> fields;
    std::stringstream stream(line);
    std::string field;
    while (std::getline(stream, field, ','))
    {
      fields.push_back(field);
    }
    if (!line.empty() && line.back() == ',')
    {
      fields.emplace_back();
    }
    rows.push_back(fields);
  }
  return rows;
}

bool waitFor(const std::function<bool()>& condition)
{
  for (int i = 0; i < 500 && !condition(); ++i)
  {
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  return condition();
}

TEST(LatencyProbe, WritesEachFramesLatencyToItsObjectsAndLeavesItEmptyWithout)
{
  const fs::path csv = fs::temp_directory_path() / ("latency_probe_" + std::to_string(getpid()) + ".csv");
  ros::NodeHandle nh;
  ros::Publisher info_pub = nh.advertise<sensor_msgs::CameraInfo>("/kitti/camera_color_left/camera_info", 10);
  ros::Publisher objects_pub = nh.advertise<grid_vision_fusion::DetectedObjectArray>("/objects", 10);

  const std::string program = LATENCY_PROBE;
  const std::string output = csv.string();
  // A ROS remapping among the options: ros::init takes it out before the options are read, and
  // the probe's --objects topic is remapped to the one published here.
  std::vector<char*> argv{const_cast<char*>(program.c_str()),
                          const_cast<char*>("--output"),
                          const_cast<char*>(output.c_str()),
                          const_cast<char*>("/objects_elsewhere:=/objects"),
                          const_cast<char*>("--objects=/objects_elsewhere"),
                          nullptr};
  pid_t pid = 0;
  ASSERT_EQ(posix_spawn(&pid, program.c_str(), nullptr, nullptr, argv.data(), environ), 0) << program;
  ASSERT_TRUE(
      waitFor([&] { return info_pub.getNumSubscribers() > 0 && objects_pub.getNumSubscribers() > 0; }))
      << "the probe did not subscribe";

  sensor_msgs::CameraInfo info;
  info.header.stamp = ros::Time(100, 0);
  info_pub.publish(info);
  std::this_thread::sleep_for(std::chrono::milliseconds(100));
  grid_vision_fusion::DetectedObjectArray objects;
  objects.header.stamp = info.header.stamp;
  objects_pub.publish(objects);
  objects_pub.publish(objects);  // a second array of the same stamp does not count
  info.header.stamp = ros::Time(100, 100000000);
  info_pub.publish(info);  // no objects for this one
  std::this_thread::sleep_for(std::chrono::milliseconds(300));

  ASSERT_EQ(kill(pid, SIGINT), 0);
  int status = 0;
  ASSERT_EQ(waitpid(pid, &status, 0), pid);
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 0);

  const auto rows = csvRows(csv);
  ASSERT_EQ(rows.size(), 2U);
  ASSERT_EQ(rows[0].size(), 3U);
  EXPECT_EQ(rows[0][0], "100000000000");
  EXPECT_GT(std::stod(rows[0][2]), 0.09);  // published 0.1 s after the camera_info
  EXPECT_LT(std::stod(rows[0][2]), 0.3);
  ASSERT_EQ(rows[1].size(), 3U);
  EXPECT_EQ(rows[1][0], "100100000000");
  EXPECT_EQ(rows[1][2], "");
  fs::remove(csv);
}
}  // namespace

int main(int argc, char** argv)
{
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_latency_probe");
  ros::AsyncSpinner spinner(1);
  spinner.start();
  return RUN_ALL_TESTS();
}
