// make_synthetic_drive: writes a synthetic drive with exact ground truth in the KITTI raw layout.
//
//   rosrun grid_vision_fusion make_synthetic_drive --output ~/kitti_synthetic
//       [--scenario config/synthetic_drive.yaml] [--calibration data/calibration/2011_09_26]
//       [--drive 9001] [--frames N] [--seed S] [--from-drive RECORDED_DRIVE_DIR]
#include <unistd.h>

#include <cstdlib>
#include <iostream>
#include <stdexcept>
#include <string>

#include "grid_vision_fusion/cli/package_path.h"
#include "grid_vision_fusion/cli/progress_bar.h"
#include "grid_vision_fusion/simulation/synthetic_drive.h"

namespace
{
const char* const kUsage =
    "usage: make_synthetic_drive --output DIR [options]\n"
    "\n"
    "Simulates the scenario (ego vehicle, actors, buildings) with the KITTI sensor set-up and\n"
    "writes DIR/<date>/<date>_drive_<NNNN>_sync in the KITTI raw layout: image_02 (PNG),\n"
    "velodyne_points (.bin), oxts, timestamps, tracklet_labels.xml, label_2 (KITTI object labels),\n"
    "and the day's calibration files in DIR/<date>/.\n"
    "\n"
    "options:\n"
    "  --output DIR        root of the written dataset (required)\n"
    "  --scenario FILE     scenario YAML (default: the package's config/synthetic_drive.yaml)\n"
    "  --calibration DIR   KITTI calibration of a recording day (default: the package's\n"
    "                      data/calibration/2011_09_26)\n"
    "  --date DATE         recording day in folder names (default 2011_09_26)\n"
    "  --drive N           drive number, 0..9999 (default 9001)\n"
    "  --frames N          write only the first N frames (default: the whole scenario)\n"
    "  --seed S            override the scenario's random seed (lidar noise, dropouts)\n"
    "  --from-drive DIR    replay a recorded KITTI raw drive instead: the ego follows its\n"
    "                      oxts/, the actors its tracklet_labels.xml (road, scenery and lidar\n"
    "                      settings from --scenario when given, else an empty flat world)\n"
    "  -h, --help          this text\n";

int fail(const std::string& message)
{
  std::cerr << "make_synthetic_drive: " << message << '\n';
  return 1;
}

int parseInt(const std::string& option, const std::string& value)
{
  std::size_t used = 0;
  try
  {
    const int parsed = std::stoi(value, &used);
    if (used == value.size())
    {
      return parsed;
    }
  }
  catch (const std::exception&)
  {
  }
  throw std::invalid_argument(option + " needs an integer, got \"" + value + "\"");
}
}  // namespace

int main(int argc, char** argv)
{
  using namespace grid_vision_fusion;
  SyntheticDriveOptions options;
  std::string scenario_path;
  std::string recorded_drive;
  int seed = -1;
  try
  {
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
      if (arg == "--output")
      {
        options.output_root = value;
      }
      else if (arg == "--scenario")
      {
        scenario_path = value;
      }
      else if (arg == "--calibration")
      {
        options.calibration_dir = value;
      }
      else if (arg == "--date")
      {
        options.date = value;
      }
      else if (arg == "--drive")
      {
        options.drive_number = parseInt(arg, value);
      }
      else if (arg == "--frames")
      {
        options.max_frames = parseInt(arg, value);
      }
      else if (arg == "--seed")
      {
        seed = parseInt(arg, value);
      }
      else if (arg == "--from-drive")
      {
        recorded_drive = value;
      }
      else
      {
        return fail("unknown option " + arg + "\n\n" + kUsage);
      }
    }
    if (options.output_root.empty())
    {
      return fail(std::string("--output is required\n\n") + kUsage);
    }
    const bool explicit_scenario = !scenario_path.empty();
    if (scenario_path.empty() || options.calibration_dir.empty())
    {
      const std::string package =
          packagePath(scenario_path.empty()
                          ? (options.calibration_dir.empty() ? "--scenario and --calibration" : "--scenario")
                          : "--calibration");
      if (scenario_path.empty())
      {
        scenario_path = package + "/config/synthetic_drive.yaml";
      }
      if (options.calibration_dir.empty())
      {
        options.calibration_dir = package + "/data/calibration/2011_09_26";
      }
    }

    SyntheticScenario scenario;
    if (recorded_drive.empty())
    {
      scenario = loadScenario(scenario_path);
    }
    else
    {
      const SyntheticScenario base = explicit_scenario ? loadScenario(scenario_path) : SyntheticScenario{};
      scenario = recordedDriveScenario(recorded_drive,
                                       KittiRawCalibration::readDirectory(options.calibration_dir), base);
      scenario_path = recorded_drive;
    }
    if (seed >= 0)
    {
      scenario.seed = static_cast<std::uint32_t>(seed);
    }
    const int frames =
        options.max_frames >= 0 ? std::min(options.max_frames, scenario.frameCount()) : scenario.frameCount();
    std::cerr << "make_synthetic_drive: " << scenario_path << ": " << scenario.actors.size() << " actors, "
              << scenario.scenery.size() << " buildings, " << frames << " frames at "
              << scenario.frame_rate_hz << " Hz\n";
    ProgressBar bar(std::cerr, static_cast<std::size_t>(frames), "frames", isatty(STDERR_FILENO) != 0);
    const SyntheticDriveSummary summary = writeSyntheticDrive(
        scenario, options, [&](int done, int) { bar.update(static_cast<std::size_t>(done)); });
    bar.finish();
    std::cout << "wrote " << summary.drive_dir << ": " << summary.frames << " frames, "
              << summary.lidar_points / std::max(summary.frames, 1) << " lidar points per scan on average, "
              << summary.labels << " object labels\n";
  }
  catch (const std::exception& e)
  {
    return fail(e.what());
  }
  return 0;
}
