// bag_summary: what a recorded run of the perception chain contains. Prints objects per frame,
// the static/dynamic/unknown counts per class and the tracks (objects by id) of a
// DetectedObjectArray topic, and exports the overlay images (objects/image) as PNG frames and an
// MJPG video.
//
//   rosrun grid_vision_fusion bag_summary --bag objects.bag [--objects /objects]
//       [--images /objects/image] [--frames-dir DIR] [--video FILE.avi]
#include <cv_bridge/cv_bridge.h>
#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <sensor_msgs/Image.h>
#include <sensor_msgs/image_encodings.h>
#include <unistd.h>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/videoio.hpp>

#include <cstdio>
#include <filesystem>
#include <iostream>
#include <map>
#include <optional>
#include <string>

#include "grid_vision_fusion/DetectedObjectArray.h"
#include "grid_vision_fusion/cli/progress_bar.h"
#include "grid_vision_fusion/cli/temporary_output.h"
#include "grid_vision_fusion/fusion/fusion.h"
#include "grid_vision_fusion/offline/bag_errors.h"

namespace
{
const char* const kUsage =
    "usage: bag_summary --bag FILE [options]\n"
    "\n"
    "Summarises a bag recorded from the perception chain: objects per frame, static / dynamic /\n"
    "unknown counts per class, mean speed of the dynamic objects, the tracks (objects by id: label,\n"
    "frames, time span, motion counts and changes); exports the overlay images.\n"
    "\n"
    "options:\n"
    "  --bag FILE         the recorded bag (required)\n"
    "  --objects TOPIC    DetectedObjectArray topic (default /objects)\n"
    "  --images TOPIC     overlay image topic (default /objects/image)\n"
    "  --frames-dir DIR   write every overlay image as DIR/NNNNNN.png\n"
    "  --video FILE       write the overlay images as an MJPG .avi video at 10 fps\n"
    "  -h, --help         this text\n";

int fail(const std::string& message)
{
  std::cerr << "bag_summary: " << message << '\n';
  return 1;
}

struct Counts
{
  std::size_t by_motion[3] = {0, 0, 0};
  double dynamic_speed_sum = 0.0;
};

/// One id of the objects (a track where the fusion tracks).
struct TrackSummary
{
  std::string label;
  Counts counts;
  double first_s = 0.0;
  double last_s = 0.0;
  std::uint8_t last_motion = 0;
  std::size_t motion_changes = 0;
};
}  // namespace

int main(int argc, char** argv)
{
  using grid_vision_fusion::DetectedObject;
  using grid_vision_fusion::DetectedObjectArray;
  std::string bag_path, objects_topic = "/objects", images_topic = "/objects/image", frames_dir, video_path;
  for (int i = 1; i < argc; ++i)
  {
    const std::string arg = argv[i];
    if (arg == "-h" || arg == "--help")
    {
      std::cout << kUsage;
      return 0;
    }
    if (i + 1 >= argc)
    {
      return fail("option " + arg + " needs a value (or is unknown)\n\n" + kUsage);
    }
    const std::string value = argv[++i];
    if (arg == "--bag")
    {
      bag_path = value;
    }
    else if (arg == "--objects")
    {
      objects_topic = value;
    }
    else if (arg == "--images")
    {
      images_topic = value;
    }
    else if (arg == "--frames-dir")
    {
      frames_dir = value;
    }
    else if (arg == "--video")
    {
      video_path = value;
    }
    else
    {
      return fail("unknown option " + arg + "\n\n" + kUsage);
    }
  }
  if (bag_path.empty())
  {
    return fail(std::string("--bag is required\n\n") + kUsage);
  }
  try
  {
    rosbag::Bag bag(bag_path, rosbag::bagmode::Read);
    rosbag::View view(bag, rosbag::TopicQuery(std::vector<std::string>{objects_topic, images_topic}));
    // The frames and the video are written under temporary names and moved in place at the end,
    // so that a failure leaves no partial output behind.
    std::optional<grid_vision_fusion::TemporaryOutput> frames_out, video_out;
    if (!frames_dir.empty())
    {
      frames_out.emplace(frames_dir);
      std::filesystem::create_directories(frames_out->temporary());
    }
    if (!video_path.empty())
    {
      video_out.emplace(video_path, ".tmp.avi");
    }
    std::map<std::string, Counts> per_class;
    std::map<std::uint32_t, TrackSummary> tracks;
    std::map<std::size_t, std::size_t> frames_with_n_objects;
    std::size_t frames = 0, images = 0;
    cv::VideoWriter video;
    grid_vision_fusion::ProgressBar bar(std::cerr, view.size(), "messages", isatty(STDERR_FILENO) != 0);
    std::size_t done = 0;
    for (const rosbag::MessageInstance& m : view)
    {
      bar.update(++done);
      if (const auto objects = m.instantiate<DetectedObjectArray>())
      {
        ++frames;
        ++frames_with_n_objects[objects->objects.size()];
        const double stamp_s = objects->header.stamp.toSec();
        for (const DetectedObject& o : objects->objects)
        {
          const auto [entry, created] = tracks.try_emplace(o.id);
          TrackSummary& track = entry->second;
          if (created)
          {
            track.label = o.label;
            track.first_s = stamp_s;
          }
          else if (o.motion != track.last_motion)
          {
            ++track.motion_changes;
          }
          track.last_s = stamp_s;
          track.last_motion = o.motion;
          for (Counts* c : {&per_class[o.label], &track.counts})
          {
            ++c->by_motion[std::min<std::size_t>(o.motion, 2)];
            if (o.motion == DetectedObject::MOTION_DYNAMIC)
            {
              c->dynamic_speed_sum += std::hypot(o.velocity.x, o.velocity.y);
            }
          }
        }
      }
      else if (const auto image = m.instantiate<sensor_msgs::Image>())
      {
        if (frames_dir.empty() && video_path.empty())
        {
          continue;
        }
        const cv::Mat bgr = cv_bridge::toCvCopy(image, sensor_msgs::image_encodings::BGR8)->image;
        if (!frames_dir.empty())
        {
          char name[32];
          std::snprintf(name, sizeof(name), "%06zu.png", images);
          const std::string path = (std::filesystem::path(frames_out->temporary()) / name).string();
          if (!cv::imwrite(path, bgr))
          {
            return fail("cannot write " + path);
          }
        }
        if (!video_path.empty())
        {
          if (!video.isOpened() && !video.open(video_out->temporary(),
                                               cv::VideoWriter::fourcc('M', 'J', 'P', 'G'), 10.0, bgr.size()))
          {
            return fail("cannot open the video " + video_path + " for writing");
          }
          video.write(bgr);
        }
        ++images;
      }
    }
    bar.finish();
    if (frames == 0)
    {
      return fail("no " + objects_topic + " message in " + bag_path);
    }
    if (frames_out)
    {
      frames_out->commit();
    }
    if (video_out && video.isOpened())
    {
      video.release();
      video_out->commit();
    }
    std::cout << "\n"
              << frames << " frames of " << objects_topic << ", " << images << " overlay images of "
              << images_topic << "\n\nobjects per frame:\n";
    for (const auto& [count, n] : frames_with_n_objects)
    {
      std::cout << "  " << count << " object(s): " << n << " frame(s)\n";
    }
    std::cout << "\nclass          static  dynamic  unknown  mean speed of dynamic [m/s]\n";
    for (const auto& [label, c] : per_class)
    {
      char line[160];
      std::snprintf(
          line, sizeof(line), "%-12s %8zu %8zu %8zu  %s\n", label.c_str(), c.by_motion[1], c.by_motion[2],
          c.by_motion[0],
          c.by_motion[2] ? std::to_string(c.dynamic_speed_sum / c.by_motion[2]).substr(0, 5).c_str() : "-");
      std::cout << line;
    }
    std::cout
        << "\n"
        << tracks.size() << " tracks (objects by id; with tracking off the id is the index in the array)\n"
        << "id       label        frames  first [s]     last [s]   static  dynamic  unknown  changes  mean "
           "speed of dynamic [m/s]\n";
    for (const auto& [id, t] : tracks)
    {
      const std::size_t frames_seen = t.counts.by_motion[0] + t.counts.by_motion[1] + t.counts.by_motion[2];
      char line[200];
      std::snprintf(
          line, sizeof(line), "%-8u %-12s %6zu %10.3f %12.3f %8zu %8zu %8zu %8zu  %s\n", id, t.label.c_str(),
          frames_seen, t.first_s, t.last_s, t.counts.by_motion[1], t.counts.by_motion[2],
          t.counts.by_motion[0], t.motion_changes,
          t.counts.by_motion[2]
              ? std::to_string(t.counts.dynamic_speed_sum / t.counts.by_motion[2]).substr(0, 5).c_str()
              : "-");
      std::cout << line;
    }
  }
  catch (const rosbag::BagException& e)
  {
    return fail(grid_vision_fusion::bagReadError(bag_path, e.what()));
  }
  catch (const std::exception& e)
  {
    return fail(bag_path + ": " + e.what());
  }
  return 0;
}
