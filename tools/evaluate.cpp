// evaluate: scores the detections of a run (a bag of DetectedObjectArray) against the ground
// truth of a KITTI raw drive (tracklets, or the KITTI tracking labels of the drive's sequence, or
// label files with a motion column; with the drive's OXTS and calibration) and writes
// metrics.json, report.md, matches.csv, the Cartucho/mAP folders and the plots.
//
//   rosrun grid_vision_fusion evaluate --drive <drive_sync dir> --detections <bag> --output <dir>
//
// Progress and notes go to stderr, the report tables to stdout. See doc/tools/evaluate.md.
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <iostream>
#include <map>
#include <memory>
#include <set>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "grid_vision_fusion/cli/command_line.h"
#include "grid_vision_fusion/cli/progress_bar.h"
#include "grid_vision_fusion/cli/temporary_output.h"
#include "grid_vision_fusion/evaluation/evaluation.h"
#include "grid_vision_fusion/evaluation/evaluation_report.h"
#include "grid_vision_fusion/evaluation/kitti_ground_truth.h"
#include "grid_vision_fusion/offline/detection_bag.h"

namespace gvf = grid_vision_fusion;

namespace
{
const char* const kUsage = R"(usage: evaluate --drive <dir> --detections <bag> --output <dir> [options]

Scores the detections of a run against the ground truth of a KITTI raw drive.

required:
  --drive <dir>            KITTI raw synced drive (image_02/timestamps.txt, oxts/, tracklet_labels.xml)
  --detections <bag>       bag with grid_vision_fusion/DetectedObjectArray messages
  --output <dir>           where metrics.json, report.md, matches.csv, ground-truth/,
                           detection-results/ and the PNG plots are written (created if needed)
options:
  --calibration <dir>      folder of calib_cam_to_cam.txt, calib_velo_to_cam.txt,
                           calib_imu_to_velo.txt (default: the parent folder of --drive)
  --tracking-labels <file> ground truth from a KITTI tracking label file (label_02/NNNN.txt of the
                           sequence that is this drive) instead of tracklet_labels.xml; the drive
                           still gives the time stamps, the ego poses and the calibration
  --labels <dir>           ground truth from label files <frame>.txt (KITTI object format plus a
                           final static/dynamic column) instead of tracklet_labels.xml
  --topic <name>           DetectedObjectArray topic (default /objects)
  --world-frame <name>     header.frame_id of detections in the truth's frame (default world)
  --odom-frame <name>      header.frame_id of detections in the odometry frame, moved into the
                           world frame with the drive's dead-reckoned OXTS poses (default odom)
  --stamp-tolerance <s>    largest |message stamp - image stamp| of a match (default 0.05)
  --max-range <m>          longitudinal distance limit: ground truth beyond it is ignored,
                           detections beyond it count only as true positives (default 30)
  --iou <x>                IoU of a true positive, (0, 1] (default 0.5)
  --dynamic-speed <m/s>    ground truth faster than this is dynamic (default 0.5)
  --speed-window <s>       tracking labels: velocity fitted over at least this span (default 1)
  --max-truncation <x>     ground truth truncated more than this is difficult (default 0.5)
  --difficult-occlusion <n> ground truth occluded this much or more is difficult (default 2)
  --classes <a,b,...>      evaluate only these (lower-case) classes, e.g. car,van (default: all)
  --map <from=to,...>      rename classes (lower-case; "from=" drops a class), e.g. truck=van
  --no-motion-classes      classes without the motion prefix (car instead of staticCar/dynamicCar)
  --all-frames             count the ground truth of every frame, also of frames without a
                           detection message (default: only frames the bag covers)
  -h, --help               this text
)";

struct Options
{
  std::string drive, calibration, labels, tracking_labels, detections, output;
  gvf::DetectionBagConfig bag;
  gvf::EvaluationConfig evaluation;
  gvf::KittiGroundTruthConfig truth;
  bool all_frames = false;
};

using gvf::UsageError;

std::vector<std::string> splitComma(const std::string& text)
{
  std::vector<std::string> parts;
  std::stringstream in(text);
  for (std::string part; std::getline(in, part, ',');)
  {
    if (!part.empty())
    {
      parts.push_back(part);
    }
  }
  return parts;
}

/// --map from=to,...: adds the renamings to `class_map`.
void parseClassMap(const std::string& text, std::map<std::string, std::string>& class_map)
{
  for (const std::string& pair : splitComma(text))
  {
    const auto eq = pair.find('=');
    if (eq == std::string::npos || eq == 0)
    {
      throw UsageError("--map expects from=to pairs, got '" + pair + "'");
    }
    class_map[pair.substr(0, eq)] = pair.substr(eq + 1);
  }
}

/// --classes a,b,...: keeps the listed classes (after renaming), every other class is dropped.
void keepOnly(const std::vector<std::string>& classes, gvf::KittiGroundTruthConfig& truth)
{
  if (classes.empty())
  {
    return;
  }
  truth.keep_unmapped = false;
  const std::set<std::string> keep(classes.begin(), classes.end());
  for (auto& [from, to] : truth.class_map)
  {
    if (!keep.count(to))
    {
      to.clear();
    }
  }
  for (const std::string& name : keep)
  {
    truth.class_map.emplace(name, name);
  }
}

/// The options of the command line, bound to the fields of `o` where a value goes as it is.
boost::program_options::options_description describeOptions(Options& o)
{
  namespace po = boost::program_options;
  po::options_description options;
  options.add_options()                                                 //
      ("drive", po::value(&o.drive))                                    //
      ("detections", po::value(&o.detections))                          //
      ("output", po::value(&o.output))                                  //
      ("calibration", po::value(&o.calibration))                        //
      ("tracking-labels", po::value(&o.tracking_labels))                //
      ("labels", po::value(&o.labels))                                  //
      ("topic", po::value(&o.bag.topic))                                //
      ("world-frame", po::value(&o.bag.world_frame))                    //
      ("odom-frame", po::value(&o.bag.odom_frame))                      //
      ("stamp-tolerance", po::value(&o.bag.stamp_tolerance_s))          //
      ("max-range", po::value(&o.evaluation.max_longitudinal_m))        //
      ("iou", po::value(&o.evaluation.iou_threshold))                   //
      ("dynamic-speed", po::value(&o.truth.dynamic_speed_mps))          //
      ("speed-window", po::value(&o.truth.speed_window_s))              //
      ("max-truncation", po::value(&o.truth.max_truncation))            //
      ("difficult-occlusion", po::value(&o.truth.difficult_occlusion))  //
      ("classes", po::value<std::string>())                             //
      ("map", po::value<std::string>())                                 //
      ("no-motion-classes", po::bool_switch())                          //
      ("all-frames", po::bool_switch(&o.all_frames))                    //
      ("help,h", po::bool_switch());
  return options;
}

/// Reads the command line into `o`; false when --help was asked for. @throws UsageError
bool parseArguments(int argc, char** argv, Options& o)
{
  const boost::program_options::variables_map given = gvf::parseCommandLine(argc, argv, describeOptions(o));
  if (given["help"].as<bool>())
  {
    return false;
  }
  o.evaluation.motion_classes = !given["no-motion-classes"].as<bool>();
  if (given.count("map"))
  {
    parseClassMap(given["map"].as<std::string>(), o.truth.class_map);
  }
  if (given.count("classes"))
  {
    keepOnly(splitComma(given["classes"].as<std::string>()), o.truth);
  }
  if (o.drive.empty() || o.detections.empty() || o.output.empty())
  {
    throw UsageError("--drive, --detections and --output are required");
  }
  if (!o.labels.empty() && !o.tracking_labels.empty())
  {
    throw UsageError("--labels and --tracking-labels are two sources of ground truth: give one");
  }
  try
  {
    o.bag.validate();
    o.evaluation.validate();
    o.truth.validate();
  }
  catch (const std::invalid_argument& e)
  {
    throw UsageError(e.what());
  }
  return true;
}

/// Where the ground truth comes from, in words.
std::string truthSource(const Options& o)
{
  if (!o.tracking_labels.empty())
  {
    return o.tracking_labels;
  }
  return o.labels.empty() ? o.drive + "/tracklet_labels.xml" : o.labels;
}

/// The ground truth of the drive from the source the options name; warns on stderr about
/// tracking labels beyond the drive's frames.
std::vector<gvf::GroundTruthObject> readGroundTruth(const Options& o, const gvf::KittiDrive& drive)
{
  if (!o.labels.empty())
  {
    return gvf::labelFolderGroundTruth(o.labels, drive.calibration, o.truth);
  }
  if (o.tracking_labels.empty())
  {
    return gvf::trackletGroundTruth(drive, o.truth);
  }
  gvf::TrackingGroundTruth truth =
      gvf::trackingLabelGroundTruth(gvf::readTrackingLabels(o.tracking_labels), drive, o.truth);
  if (truth.beyond_drive > 0)
  {
    std::cerr << "warning: " << o.tracking_labels << ": " << truth.beyond_drive << " labels of frames "
              << truth.first_frame_beyond << ".." << truth.last_frame_beyond << " (the first on line "
              << truth.first_line_beyond << ") lie beyond the " << drive.frameCount() << " frames of "
              << o.drive << "; left out (is it the label file of this drive?)\n";
  }
  return std::move(truth.objects);
}

/// @throws std::runtime_error when the ground truth should come from the drive's tracklets but it
///         has none, saying which other source to give.
void checkTrackletsExist(const Options& o)
{
  const bool tracklets = o.labels.empty() && o.tracking_labels.empty();
  if (tracklets && std::filesystem::is_directory(o.drive) &&
      !std::filesystem::exists(o.drive + "/tracklet_labels.xml"))
  {
    const std::string label_2 = o.drive + "/label_2";
    throw std::runtime_error(
        o.drive + "/tracklet_labels.xml: no such file, so this drive has no tracklets: give " +
        "its ground truth with --labels DIR (KITTI label files, one per frame" +
        (std::filesystem::is_directory(label_2) ? ", e.g. --labels " + label_2 : std::string()) +
        ") or --tracking-labels FILE (a KITTI tracking sequence's label_02 file)");
  }
}

/// The detections of the bag, with a progress bar on stderr.
gvf::DetectionBagResult readDetections(const Options& o, const gvf::KittiDrive& drive)
{
  const bool tty = isatty(STDERR_FILENO) != 0;
  std::size_t bar_total = 0;
  std::unique_ptr<gvf::ProgressBar> progress;
  gvf::DetectionBagResult bag = gvf::readDetectionBag(o.detections, drive, o.bag, o.truth,
                                                      [&](std::size_t done, std::size_t total)
                                                      {
                                                        if (!progress || total != bar_total)
                                                        {
                                                          bar_total = total;
                                                          progress = std::make_unique<gvf::ProgressBar>(
                                                              std::cerr, total, "detections", tty);
                                                        }
                                                        progress->update(done);
                                                      });
  if (progress)
  {
    progress->finish();
  }
  std::cerr << "Detections: " << bag.detections.size() << " objects in " << bag.frames.size()
            << " frames from " << bag.stats.messages << " messages on " << o.bag.topic << "\n";
  if (bag.frames.empty())
  {
    throw std::runtime_error("none of the " + std::to_string(bag.stats.messages) + " messages on " +
                             o.bag.topic + " of " + o.detections + " lies within " +
                             std::to_string(o.bag.stamp_tolerance_s) + " s of a time stamp of " + o.drive +
                             "/image_02/timestamps.txt: is the bag from this drive?");
  }
  return bag;
}

/// Warns on stderr about what of the bag is left out or looks wrong.
void warnAboutDetections(const Options& o, const gvf::DetectionBagResult& bag)
{
  const gvf::DetectionBagStats& s = bag.stats;
  if (bag.detections.empty())
  {
    std::cerr
        << "warning: the " << s.messages << " messages on " << o.bag.topic
        << " hold no object, so every labelled object counts as missed: the detector found nothing (a "
           "model trained on COCO finds nothing on a synthetic drive's flat-shaded boxes: replay its label_2 "
           "with --backend replay), or the fusion dropped the boxes (see the drops run_pipeline prints)\n";
  }
  if (s.unmatched > 0)
  {
    std::cerr << "warning: " << s.unmatched << " messages have no image time stamp within "
              << o.bag.stamp_tolerance_s << " s (is the bag from this drive?); left out\n";
  }
  if (s.duplicates > 0)
  {
    std::cerr << "warning: " << s.duplicates
              << " messages fall on a frame that already had one; the nearer in time is kept\n";
  }
  if (s.other_frame > 0)
  {
    std::cerr << "warning: " << s.other_frame << " messages are neither in frame '" << o.bag.world_frame
              << "' nor in '" << o.bag.odom_frame << "': their positions are compared as if in the first\n";
  }
  if (s.invalid_objects > 0)
  {
    std::cerr << "warning: " << s.invalid_objects
              << " objects with a non-finite or inverted box, score or position left out\n";
  }
}

/// Without --all-frames: leaves out the ground truth of the frames the bag does not cover.
void leaveOutUncoveredFrames(const Options& o, const gvf::KittiDrive& drive,
                             const gvf::DetectionBagResult& bag, std::vector<gvf::GroundTruthObject>& truth)
{
  if (o.all_frames)
  {
    return;
  }
  const std::size_t before = truth.size();
  truth.erase(
      std::remove_if(truth.begin(), truth.end(),
                     [&](const gvf::GroundTruthObject& g) { return !bag.frames.count(g.frame_index); }),
      truth.end());
  if (truth.size() != before)
  {
    std::cerr << "Left out " << before - truth.size() << " ground-truth objects of the "
              << drive.frameCount() - static_cast<int>(bag.frames.size())
              << " frames without a detection message (--all-frames counts them)\n";
  }
}

/// Scores the detections, writes the outputs into o.output and the report to stdout.
void evaluateAndWrite(const Options& o, const std::vector<gvf::GroundTruthObject>& truth,
                      const gvf::DetectionBagResult& bag)
{
  const std::vector<gvf::EvalObject> ground_truth = gvf::evalObjects(truth);
  gvf::EvaluationResult result = gvf::evaluate(ground_truth, bag.detections, o.evaluation);
  if (o.labels.empty())  // tracklets and tracking labels give the ground-truth identities
  {
    gvf::TrackingEvaluationConfig tracking;
    tracking.iou_threshold = o.evaluation.iou_threshold;
    tracking.max_longitudinal_m = o.evaluation.max_longitudinal_m;
    result.tracking = gvf::evaluateTracking(ground_truth, bag.detections, tracking);
  }
  // Written into OUTPUT.tmp and moved into OUTPUT when complete; removed on any failure.
  gvf::TemporaryOutput output(o.output);
  gvf::writeEvaluationOutputs(output.temporary(), result, o.evaluation, ground_truth, bag.detections);
  output.commit();
  std::cout << gvf::reportMarkdown(result, o.evaluation);
  std::cerr << "Wrote " << o.output
            << "/metrics.json, report.md, matches.csv, ground-truth/, detection-results/ and the plots\n";
}

int run(const Options& o)
{
  std::cerr << "Reading the drive " << o.drive << "\n";
  checkTrackletsExist(o);
  const bool tracklets = o.labels.empty() && o.tracking_labels.empty();
  const gvf::KittiDrive drive = gvf::KittiDrive::read(o.drive, o.calibration, tracklets);
  std::vector<gvf::GroundTruthObject> truth = readGroundTruth(o, drive);
  const auto regions = static_cast<std::size_t>(std::count_if(
      truth.begin(), truth.end(), [](const gvf::GroundTruthObject& g) { return g.object.dont_care; }));
  std::cerr << "Ground truth: " << truth.size() - regions << " objects"
            << (regions ? " and " + std::to_string(regions) + " DontCare regions" : std::string()) << " in "
            << drive.frameCount() << " frames from " << truthSource(o) << "\n";
  const gvf::DetectionBagResult bag = readDetections(o, drive);
  warnAboutDetections(o, bag);
  leaveOutUncoveredFrames(o, drive, bag, truth);
  evaluateAndWrite(o, truth, bag);
  return 0;
}
}  // namespace

int main(int argc, char** argv)
{
  Options options;
  if (const auto status =
          gvf::readCommandLine("evaluate", kUsage, 2, [&] { return parseArguments(argc, argv, options); }))
  {
    return *status;
  }
  try
  {
    return run(options);
  }
  catch (const std::exception& e)
  {
    std::cerr << "\nevaluate: error: " << e.what() << "\n";
    return 1;
  }
}
