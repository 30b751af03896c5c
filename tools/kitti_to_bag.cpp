// kitti_to_bag: converts a KITTI raw synced drive into a ROS bag with kitti2bag's topic and frame
// names and the camera model of the rectified images (see doc/tools/kitti_to_bag.md).
#include "grid_vision_fusion/cli/command_line.h"
#include "grid_vision_fusion/cli/progress_bar.h"
#include "grid_vision_fusion/offline/kitti_bag_writer.h"

#include <ros/time.h>

#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <exception>
#include <iostream>
#include <memory>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace
{
constexpr int kExitUsage = 2;
constexpr int kExitFailure = 1;

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

using grid_vision_fusion::UsageError;

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
  namespace po = boost::program_options;
  std::string first, last, cameras;
  bool help = false;
  po::options_description described;
  described.add_options()                               //
      ("calib,c", po::value(&options.calibration_dir))  //
      ("first,f", po::value(&first))                    //
      ("last,l", po::value(&last))                      //
      ("cameras", po::value(&cameras))                  //
      ("compression", po::value(&options.compression))  //
      ("quiet,q", po::bool_switch(&quiet))              //
      ("help,h", po::bool_switch(&help));
  std::vector<std::string> positional;
  const po::variables_map given = grid_vision_fusion::parseCommandLine(argc, argv, described, &positional);
  if (help)
  {
    return false;
  }
  if (given.count("first"))
  {
    options.first_frame = parseFrame("--first", first);
  }
  if (given.count("last"))
  {
    options.last_frame = parseFrame("--last", last);
  }
  if (given.count("cameras"))
  {
    options.cameras = parseCameras(cameras);
  }
  if (positional.size() != 2)
  {
    throw UsageError("want DRIVE_DIR and OUTPUT.bag, got " + std::to_string(positional.size()) +
                     " argument(s)");
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

}  // namespace

int main(int argc, char** argv)
{
  grid_vision_fusion::KittiBagOptions options;
  bool quiet = false;
  if (const auto status = grid_vision_fusion::readCommandLine(
          "kitti_to_bag", kUsage, kExitUsage, [&] { return parseArguments(argc, argv, options, quiet); }))
  {
    return *status;
  }

  ros::Time::init();
  const bool terminal = isatty(STDERR_FILENO) != 0;
  std::unique_ptr<grid_vision_fusion::ProgressBar> progress;
  if (!quiet)
  {
    options.progress = [&progress, terminal](std::size_t done, std::size_t total)
    {
      if (!progress)
      {
        progress = std::make_unique<grid_vision_fusion::ProgressBar>(std::cerr, total, "kitti_to_bag frames",
                                                                     terminal);
      }
      progress->update(done);
    };
  }
  try
  {
    const grid_vision_fusion::KittiBagSummary summary = grid_vision_fusion::convertKittiDrive(options);
    if (progress)
    {
      progress->finish();
    }
    if (!quiet)
    {
      std::cerr << "kitti_to_bag: wrote " << summary.frames << " frames (" << summary.messages
                << " messages) to " << summary.output_bag << "\n";
    }
  }
  catch (const std::exception& e)
  {
    if (progress && terminal)
    {
      std::cerr << '\n';  // end the partly drawn bar
    }
    std::cerr << "kitti_to_bag: error: " << e.what() << "\n";
    return kExitFailure;
  }
  return EXIT_SUCCESS;
}
