// kitti_to_bag: converts a KITTI raw synced drive into a ROS bag with kitti2bag's topic and frame
// names and the camera model of the rectified images (see doc/kitti_to_bag.md).
#include "grid_vision_fusion/ros/kitti_bag_writer.h"

#include <ros/time.h>

#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <exception>
#include <iostream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace
{
constexpr int kExitUsage = 2;
constexpr int kExitFailure = 1;
constexpr int kBarWidth = 30;

const char* const kUsage =
    "Usage: kitti_to_bag [options] DRIVE_DIR OUTPUT.bag\n"
    "\n"
    "Converts a KITTI raw synced drive (e.g. 2011_09_26/2011_09_26_drive_0001_sync) into a ROS bag\n"
    "with kitti2bag's topic and frame names; camera_info carries the rectified camera model.\n"
    "\n"
    "Options:\n"
    "  -c, --calib DIR        folder of calib_cam_to_cam.txt, calib_velo_to_cam.txt and\n"
    "                         calib_imu_to_velo.txt (default: the parent folder of DRIVE_DIR)\n"
    "  -f, --first N          first frame to convert (default: 0)\n"
    "  -l, --last N           last frame to convert, inclusive (default: the last scan of the drive)\n"
    "      --cameras LIST     comma-separated KITTI cameras: 0, 1 grey left/right, 2, 3 colour\n"
    "                         left/right (default: 2)\n"
    "      --compression C    none, bz2 or lz4 (default: none)\n"
    "  -q, --quiet            no progress output\n"
    "  -h, --help             this help\n"
    "\n"
    "The bag is written as OUTPUT.bag.tmp and renamed when complete; an existing OUTPUT.bag is\n"
    "replaced. Exit status: 0 success, 1 conversion error, 2 usage error.\n";

struct UsageError : std::runtime_error
{
  using std::runtime_error::runtime_error;
};

int parseFrame(const std::string& option, const std::string& text)
{
  std::size_t used = 0;
  long value = -1;
  try
  {
    value = std::stol(text, &used);
  }
  catch (const std::exception&)
  {
    used = 0;
  }
  if (used != text.size() || text.empty() || value < 0 || value > 999999999)
  {
    throw UsageError(option + " wants a frame index >= 0, got \"" + text + "\"");
  }
  return static_cast<int>(value);
}

std::vector<int> parseCameras(const std::string& text)
{
  std::vector<int> cameras;
  std::istringstream in(text);
  std::string item;
  while (std::getline(in, item, ','))
  {
    if (item.size() != 1 || item[0] < '0' || item[0] > '3')
    {
      throw UsageError("--cameras wants a comma-separated list of 0, 1, 2, 3, got \"" + text + "\"");
    }
    cameras.push_back(item[0] - '0');
  }
  if (cameras.empty())
  {
    throw UsageError("--cameras is empty");
  }
  return cameras;
}

/// Parses the command line; returns false when --help was asked for.
bool parseArguments(int argc, char** argv, grid_vision_fusion::KittiBagOptions& options, bool& quiet)
{
  std::vector<std::string> positional;
  for (int i = 1; i < argc; ++i)
  {
    const std::string arg = argv[i];
    const auto value = [&]() -> std::string {
      if (i + 1 >= argc)
      {
        throw UsageError(arg + " needs a value");
      }
      return argv[++i];
    };
    if (arg == "-h" || arg == "--help")
    {
      return false;
    }
    else if (arg == "-c" || arg == "--calib")
    {
      options.calibration_dir = value();
    }
    else if (arg == "-f" || arg == "--first")
    {
      options.first_frame = parseFrame(arg, value());
    }
    else if (arg == "-l" || arg == "--last")
    {
      options.last_frame = parseFrame(arg, value());
    }
    else if (arg == "--cameras")
    {
      options.cameras = parseCameras(value());
    }
    else if (arg == "--compression")
    {
      options.compression = value();
    }
    else if (arg == "-q" || arg == "--quiet")
    {
      quiet = true;
    }
    else if (arg.size() > 1 && arg[0] == '-')
    {
      throw UsageError("unknown option " + arg);
    }
    else
    {
      positional.push_back(arg);
    }
  }
  if (positional.size() != 2)
  {
    throw UsageError("want DRIVE_DIR and OUTPUT.bag, got " + std::to_string(positional.size()) + " argument(s)");
  }
  options.drive_dir = positional[0];
  options.output_bag = positional[1];
  try
  {
    options.validate();
  }
  catch (const std::invalid_argument& e)
  {
    throw UsageError(e.what());
  }
  return true;
}

/// Progress on stderr: a redrawn bar on a terminal, a line per ~10 % otherwise (logs, CI).
class ProgressReporter
{
public:
  explicit ProgressReporter(bool quiet) : quiet_(quiet), tty_(isatty(fileno(stderr)) != 0) {}

  void update(std::size_t done, std::size_t total)
  {
    if (quiet_ || total == 0)
    {
      return;
    }
    if (tty_)
    {
      const auto filled = static_cast<int>(kBarWidth * done / total);
      std::fprintf(stderr, "\r[%s%s] %zu/%zu frames", std::string(static_cast<std::size_t>(filled), '#').c_str(),
                   std::string(static_cast<std::size_t>(kBarWidth - filled), ' ').c_str(), done, total);
      if (done == total)
      {
        std::fputc('\n', stderr);
      }
      std::fflush(stderr);
      return;
    }
    const std::size_t step = total >= 10 ? total / 10 : 1;
    if (done % step == 0 || done == total)
    {
      std::fprintf(stderr, "kitti_to_bag: %zu/%zu frames\n", done, total);
    }
  }

  /// Ends a partly drawn bar before an error message.
  void interrupt()
  {
    if (!quiet_ && tty_)
    {
      std::fputc('\n', stderr);
    }
  }

private:
  bool quiet_;
  bool tty_;
};
}  // namespace

int main(int argc, char** argv)
{
  grid_vision_fusion::KittiBagOptions options;
  bool quiet = false;
  try
  {
    if (!parseArguments(argc, argv, options, quiet))
    {
      std::cout << kUsage;
      return EXIT_SUCCESS;
    }
  }
  catch (const UsageError& e)
  {
    std::cerr << "kitti_to_bag: " << e.what() << "\n\n" << kUsage;
    return kExitUsage;
  }

  ros::Time::init();
  ProgressReporter progress(quiet);
  options.progress = [&progress](std::size_t done, std::size_t total) { progress.update(done, total); };
  try
  {
    const grid_vision_fusion::KittiBagSummary summary = grid_vision_fusion::convertKittiDrive(options);
    if (!quiet)
    {
      std::cerr << "kitti_to_bag: wrote " << summary.frames << " frames (" << summary.messages << " messages) to "
                << summary.output_bag << "\n";
    }
  }
  catch (const std::exception& e)
  {
    progress.interrupt();
    std::cerr << "kitti_to_bag: error: " << e.what() << "\n";
    return kExitFailure;
  }
  return EXIT_SUCCESS;
}
