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

#include "grid_vision_fusion/cli/command_line.h"
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

/// The command line.
struct Arguments
{
  grid_vision_fusion::SyntheticDriveOptions options;
  std::string scenario_path;
  std::string recorded_drive;
  int seed = -1;
};

/// Reads the command line into `args`; false when --help was asked for.
/// @throws grid_vision_fusion::UsageError
bool parseArguments(int argc, char** argv, Arguments& args)
{
  namespace po = boost::program_options;
  bool help = false;
  po::options_description options;
  options.add_options()                                          //
      ("output", po::value(&args.options.output_root))           //
      ("scenario", po::value(&args.scenario_path))               //
      ("calibration", po::value(&args.options.calibration_dir))  //
      ("date", po::value(&args.options.date))                    //
      ("drive", po::value(&args.options.drive_number))           //
      ("frames", po::value(&args.options.max_frames))            //
      ("seed", po::value(&args.seed))                            //
      ("from-drive", po::value(&args.recorded_drive))            //
      ("help,h", po::bool_switch(&help));
  grid_vision_fusion::parseCommandLine(argc, argv, options);
  if (help)
  {
    return false;
  }
  if (args.options.output_root.empty())
  {
    throw grid_vision_fusion::UsageError("--output is required");
  }
  return true;
}

/// The scenario of the command line: its file, or the recorded drive in the world of --scenario.
grid_vision_fusion::SyntheticScenario loadArgumentsScenario(Arguments& args)
{
  using namespace grid_vision_fusion;
  const bool explicit_scenario = !args.scenario_path.empty();
  if (args.scenario_path.empty() || args.options.calibration_dir.empty())
  {
    const std::string package = packagePath(
        args.scenario_path.empty()
            ? (args.options.calibration_dir.empty() ? "--scenario and --calibration" : "--scenario")
            : "--calibration");
    if (args.scenario_path.empty())
    {
      args.scenario_path = package + "/config/synthetic_drive.yaml";
    }
    if (args.options.calibration_dir.empty())
    {
      args.options.calibration_dir = package + "/data/calibration/2011_09_26";
    }
  }
  SyntheticScenario scenario;
  if (args.recorded_drive.empty())
  {
    scenario = loadScenario(args.scenario_path);
  }
  else
  {
    const SyntheticScenario base = explicit_scenario ? loadScenario(args.scenario_path) : SyntheticScenario{};
    scenario = recordedDriveScenario(args.recorded_drive,
                                     KittiRawCalibration::readDirectory(args.options.calibration_dir), base);
    args.scenario_path = args.recorded_drive;
  }
  if (args.seed >= 0)
  {
    scenario.seed = static_cast<std::uint32_t>(args.seed);
  }
  return scenario;
}

/// ", with car profiles, a ground profile, an INS error" for what the scenario turns on.
std::string realismNote(const grid_vision_fusion::SyntheticScenario& scenario)
{
  std::string note;
  const auto add = [&](bool on, const char* what)
  { note += on ? (note.empty() ? " with " : ", ") + std::string(what) : ""; };
  bool profiles = false;
  for (const auto& actor : scenario.actors)
  {
    profiles = profiles || actor.shape != grid_vision_fusion::VehicleShape::kBox;
  }
  add(profiles, "vehicle profiles");
  add(scenario.ground.profiled() || scenario.ground.slope_x != 0.0, "a ground that is not flat");
  add(scenario.ins_error.enabled(), "an INS error in the OXTS records");
  return note;
}
}  // namespace

int main(int argc, char** argv)
{
  using namespace grid_vision_fusion;
  try
  {
    Arguments args;
    if (const auto status = readCommandLine("make_synthetic_drive", kUsage, 1,
                                            [&] { return parseArguments(argc, argv, args); }))
    {
      return *status;
    }
    const SyntheticScenario scenario = loadArgumentsScenario(args);
    const SyntheticDriveOptions& options = args.options;
    const int frames =
        options.max_frames >= 0 ? std::min(options.max_frames, scenario.frameCount()) : scenario.frameCount();
    std::cerr << "make_synthetic_drive: " << args.scenario_path << ": " << scenario.actors.size()
              << " actors, " << scenario.scenery.size() << " buildings, " << frames << " frames at "
              << scenario.frame_rate_hz << " Hz" << realismNote(scenario) << "\n";
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
