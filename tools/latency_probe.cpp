// latency_probe: the wall-clock latency from each camera frame's arrival to its objects, for
// scripts/soak.sh. Notes the first wall-clock arrival of every header stamp on a camera_info topic
// and on a DetectedObjectArray topic, and writes one CSV row per camera frame when it is ended
// (SIGINT): stamp_ns,camera_info_arrival_s,latency_s (latency empty: no objects for the frame).
//
//   rosrun grid_vision_fusion latency_probe --output FILE.csv
//       [--camera-info /kitti/camera_color_left/camera_info] [--objects /objects]
//
// A process of its own in C++, because a Python monitor that also counts the other topics notes
// arrivals late when the machine is saturated (its threads take turns on the interpreter lock):
// under overload it saw camera_infos arrive in bursts of 19, after their objects.
#include <ros/ros.h>
#include <sensor_msgs/CameraInfo.h>

#include <cstdint>
#include <cstdio>
#include <iostream>
#include <map>
#include <string>

#include "grid_vision_fusion/DetectedObjectArray.h"
#include "grid_vision_fusion/cli/command_line.h"

namespace
{
const char* const kUsage =
    "usage: latency_probe --output FILE.csv [--camera-info TOPIC] [--objects TOPIC]\n"
    "\n"
    "Writes, when ended with SIGINT, one row per camera frame: its header stamp [ns], the wall-clock\n"
    "time its camera_info arrived [s since the probe started], and the wall-clock latency from then\n"
    "to the arrival of the objects of the same stamp [s] (empty when none came).\n"
    "\n"
    "options:\n"
    "  --output FILE        the CSV file (required)\n"
    "  --camera-info TOPIC  camera_info topic (default /kitti/camera_color_left/camera_info)\n"
    "  --objects TOPIC      DetectedObjectArray topic (default /objects)\n"
    "  -h, --help           this text\n";

struct Options
{
  std::string output, camera_info_topic = "/kitti/camera_color_left/camera_info", objects_topic = "/objects";
};

/// Reads the command line (without the ROS arguments) into `o`; false when --help was asked for.
/// @throws grid_vision_fusion::UsageError
bool parseArguments(int argc, char** argv, Options& o)
{
  namespace po = boost::program_options;
  bool help = false;
  po::options_description options;
  options.add_options()                                 //
      ("output", po::value(&o.output))                  //
      ("camera-info", po::value(&o.camera_info_topic))  //
      ("objects", po::value(&o.objects_topic))          //
      ("help,h", po::bool_switch(&help));
  grid_vision_fusion::parseCommandLine(argc, argv, options);
  if (help)
  {
    return false;
  }
  if (o.output.empty())
  {
    throw grid_vision_fusion::UsageError("give --output FILE.csv");
  }
  return true;
}

std::uint64_t stampNs(const ros::Time& stamp)
{
  return static_cast<std::uint64_t>(stamp.sec) * 1000000000ULL + stamp.nsec;
}
}  // namespace

int main(int argc, char** argv)
{
  // ros::init takes the ROS remapping arguments (name:=value) out of argv first.
  ros::init(argc, argv, "latency_probe", ros::init_options::AnonymousName);
  Options o;
  if (const auto status = grid_vision_fusion::readCommandLine("latency_probe", kUsage, 1,
                                                              [&] { return parseArguments(argc, argv, o); }))
  {
    return *status;
  }
  const std::string& output = o.output;
  std::FILE* out = std::fopen(output.c_str(), "w");
  if (out == nullptr)
  {
    std::cerr << "latency_probe: cannot write --output " << output << '\n';
    return 1;
  }

  // One spinner thread: the callbacks only note the time, in the order roscpp received the messages.
  const ros::WallTime start = ros::WallTime::now();
  std::map<std::uint64_t, double> info_arrivals, objects_arrivals;  // stamp [ns] -> first arrival [s]
  ros::NodeHandle nh;
  const ros::Subscriber info_sub = nh.subscribe<sensor_msgs::CameraInfo>(
      o.camera_info_topic, 1000,
      [&](const sensor_msgs::CameraInfo::ConstPtr& msg)
      { info_arrivals.emplace(stampNs(msg->header.stamp), (ros::WallTime::now() - start).toSec()); });
  const ros::Subscriber objects_sub = nh.subscribe<grid_vision_fusion::DetectedObjectArray>(
      o.objects_topic, 1000,
      [&](const grid_vision_fusion::DetectedObjectArray::ConstPtr& msg)
      { objects_arrivals.emplace(stampNs(msg->header.stamp), (ros::WallTime::now() - start).toSec()); });
  ros::spin();

  std::fprintf(out, "stamp_ns,camera_info_arrival_s,latency_s\n");
  for (const auto& [stamp, arrived] : info_arrivals)
  {
    const auto objects = objects_arrivals.find(stamp);
    if (objects == objects_arrivals.end())
    {
      std::fprintf(out, "%llu,%.4f,\n", static_cast<unsigned long long>(stamp), arrived);
    }
    else
    {
      std::fprintf(out, "%llu,%.4f,%.4f\n", static_cast<unsigned long long>(stamp), arrived,
                   objects->second - arrived);
    }
  }
  const bool written = std::fclose(out) == 0;
  std::cerr << "latency_probe: " << info_arrivals.size() << " camera frames, " << objects_arrivals.size()
            << " object arrays" << (written ? " written to " : ", cannot write ") << output << '\n';
  return written ? 0 : 1;
}
