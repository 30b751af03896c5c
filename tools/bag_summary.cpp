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

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <map>
#include <optional>
#include <string>

#include "grid_vision_fusion/DetectedObjectArray.h"
#include "grid_vision_fusion/cli/command_line.h"
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

constexpr int kExitFailure = 1;  ///< also the exit status of usage errors

int fail(const std::string& message)
{
  std::cerr << "bag_summary: " << message << '\n';
  return kExitFailure;
}

struct Options
{
  std::string bag, objects_topic = "/objects", images_topic = "/objects/image", frames_dir, video;
};

/// Reads the command line into `o`; false when --help was asked for. @throws UsageError
bool parseArguments(int argc, char** argv, Options& o)
{
  namespace po = boost::program_options;
  bool help = false;
  po::options_description options;
  options.add_options()                         //
      ("bag", po::value(&o.bag))                //
      ("objects", po::value(&o.objects_topic))  //
      ("images", po::value(&o.images_topic))    //
      ("frames-dir", po::value(&o.frames_dir))  //
      ("video", po::value(&o.video))            //
      ("help,h", po::bool_switch(&help));
  grid_vision_fusion::parseCommandLine(argc, argv, options);
  if (help)
  {
    return false;
  }
  if (o.bag.empty())
  {
    throw grid_vision_fusion::UsageError("--bag is required");
  }
  return true;
}

/// A failure to write the frames or the video (the bag is not at fault).
struct ExportError : std::runtime_error
{
  using std::runtime_error::runtime_error;
};

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

/// What the bag holds.
struct Summary
{
  std::map<std::string, Counts> per_class;
  std::map<std::uint32_t, TrackSummary> tracks;
  std::map<std::size_t, std::size_t> frames_with_n_objects;
  std::size_t frames = 0;
  std::size_t images = 0;
};

/// Counts the objects of one message into `summary`.
void addObjects(const grid_vision_fusion::DetectedObjectArray& objects, Summary& summary)
{
  using grid_vision_fusion::DetectedObject;
  ++summary.frames;
  ++summary.frames_with_n_objects[objects.objects.size()];
  const double stamp_s = objects.header.stamp.toSec();
  for (const DetectedObject& o : objects.objects)
  {
    const auto [entry, created] = summary.tracks.try_emplace(o.id);
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
    for (Counts* c : {&summary.per_class[o.label], &track.counts})
    {
      ++c->by_motion[std::min<std::size_t>(o.motion, 2)];
      if (o.motion == DetectedObject::MOTION_DYNAMIC)
      {
        c->dynamic_speed_sum += std::hypot(o.velocity.x, o.velocity.y);
      }
    }
  }
}

/// The overlay images as PNG frames and an MJPG video, written under temporary names and moved
/// in place by commit(), so that a failure leaves no partial output behind.
class OverlayExport
{
public:
  explicit OverlayExport(const Options& o) : frames_dir_(o.frames_dir), video_path_(o.video)
  {
    if (!frames_dir_.empty())
    {
      frames_out_.emplace(frames_dir_);
      std::filesystem::create_directories(frames_out_->temporary());
    }
    if (!video_path_.empty())
    {
      video_out_.emplace(video_path_, ".tmp.avi");
    }
  }

  bool wanted() const { return frames_out_ || video_out_; }

  /// Writes overlay image number `index`. @throws ExportError
  void write(const sensor_msgs::Image::ConstPtr& image, std::size_t index)
  {
    const cv::Mat bgr = cv_bridge::toCvCopy(image, sensor_msgs::image_encodings::BGR8)->image;
    if (frames_out_)
    {
      char name[32];
      std::snprintf(name, sizeof(name), "%06zu.png", index);
      const std::string path = (std::filesystem::path(frames_out_->temporary()) / name).string();
      if (!cv::imwrite(path, bgr))
      {
        throw ExportError("cannot write " + path);
      }
    }
    if (video_out_)
    {
      if (!video_.isOpened() && !video_.open(video_out_->temporary(),
                                             cv::VideoWriter::fourcc('M', 'J', 'P', 'G'), 10.0, bgr.size()))
      {
        throw ExportError("cannot open the video " + video_path_ + " for writing");
      }
      video_.write(bgr);
    }
  }

  /// Moves the frames and the video to their final names.
  void commit()
  {
    if (frames_out_)
    {
      frames_out_->commit();
    }
    if (video_out_ && video_.isOpened())
    {
      video_.release();
      video_out_->commit();
    }
  }

private:
  std::string frames_dir_, video_path_;
  std::optional<grid_vision_fusion::TemporaryOutput> frames_out_, video_out_;
  cv::VideoWriter video_;
};

/// Reads the bag, exporting its overlay images on the way.
Summary readBag(const Options& o, OverlayExport& overlays)
{
  rosbag::Bag bag(o.bag, rosbag::bagmode::Read);
  rosbag::View view(bag, rosbag::TopicQuery(std::vector<std::string>{o.objects_topic, o.images_topic}));
  Summary summary;
  grid_vision_fusion::ProgressBar bar(std::cerr, view.size(), "messages", isatty(STDERR_FILENO) != 0);
  std::size_t done = 0;
  for (const rosbag::MessageInstance& m : view)
  {
    bar.update(++done);
    if (const auto objects = m.instantiate<grid_vision_fusion::DetectedObjectArray>())
    {
      addObjects(*objects, summary);
    }
    else if (const auto image = m.instantiate<sensor_msgs::Image>())
    {
      if (overlays.wanted())
      {
        overlays.write(image, summary.images);
        ++summary.images;
      }
    }
  }
  bar.finish();
  return summary;
}

/// The mean speed of the dynamic objects of `c` ("-" without any), 5 characters at most.
std::string meanDynamicSpeed(const Counts& c)
{
  return c.by_motion[2] ? std::to_string(c.dynamic_speed_sum / c.by_motion[2]).substr(0, 5) : "-";
}

void printSummary(const Summary& summary, const Options& o)
{
  std::cout << "\n"
            << summary.frames << " frames of " << o.objects_topic << ", " << summary.images
            << " overlay images of " << o.images_topic << "\n\nobjects per frame:\n";
  for (const auto& [count, n] : summary.frames_with_n_objects)
  {
    std::cout << "  " << count << " object(s): " << n << " frame(s)\n";
  }
  std::cout << "\nclass          static  dynamic  unknown  mean speed of dynamic [m/s]\n";
  for (const auto& [label, c] : summary.per_class)
  {
    char line[160];
    std::snprintf(line, sizeof(line), "%-12s %8zu %8zu %8zu  %s\n", label.c_str(), c.by_motion[1],
                  c.by_motion[2], c.by_motion[0], meanDynamicSpeed(c).c_str());
    std::cout << line;
  }
  std::cout
      << "\n"
      << summary.tracks.size()
      << " tracks (objects by id; with tracking off the id is the index in the array)\n"
      << "id       label        frames  first [s]     last [s]   static  dynamic  unknown  changes  mean "
         "speed of dynamic [m/s]\n";
  for (const auto& [id, t] : summary.tracks)
  {
    const std::size_t frames_seen = t.counts.by_motion[0] + t.counts.by_motion[1] + t.counts.by_motion[2];
    char line[200];
    std::snprintf(line, sizeof(line), "%-8u %-12s %6zu %10.3f %12.3f %8zu %8zu %8zu %8zu  %s\n", id,
                  t.label.c_str(), frames_seen, t.first_s, t.last_s, t.counts.by_motion[1],
                  t.counts.by_motion[2], t.counts.by_motion[0], t.motion_changes,
                  meanDynamicSpeed(t.counts).c_str());
    std::cout << line;
  }
}
}  // namespace

int main(int argc, char** argv)
{
  Options o;
  if (const auto status = grid_vision_fusion::readCommandLine("bag_summary", kUsage, kExitFailure,
                                                              [&] { return parseArguments(argc, argv, o); }))
  {
    return *status;
  }
  try
  {
    OverlayExport overlays(o);
    const Summary summary = readBag(o, overlays);
    if (summary.frames == 0)
    {
      return fail("no " + o.objects_topic + " message in " + o.bag);
    }
    overlays.commit();
    printSummary(summary, o);
  }
  catch (const ExportError& e)
  {
    return fail(e.what());
  }
  catch (const rosbag::BagException& e)
  {
    return fail(grid_vision_fusion::bagReadError(o.bag, e.what()));
  }
  catch (const std::exception& e)
  {
    return fail(o.bag + ": " + e.what());
  }
  return 0;
}
