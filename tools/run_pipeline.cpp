// run_pipeline: the four stages of grid_vision_fusion on a bag, off line (no roscore), as fast as
// the machine allows, deterministically, with the nodelets' YAML configuration files.
//
//   rosrun grid_vision_fusion run_pipeline --bag IN.bag --output OUT.bag [options]
#include <rosbag/bag.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <iostream>
#include <map>
#include <memory>
#include <sstream>
#include <stdexcept>
#include <string>
#include <tuple>
#include <vector>

#include "grid_vision_fusion/cli/command_line.h"
#include "grid_vision_fusion/cli/machine_info.h"
#include "grid_vision_fusion/cli/model_options.h"
#include "grid_vision_fusion/cli/package_path.h"
#include "grid_vision_fusion/cli/progress_bar.h"
#include "grid_vision_fusion/cli/temporary_output.h"
#include "grid_vision_fusion/offline/pipeline.h"

namespace gvf = grid_vision_fusion;

namespace
{
const char* const kUsage = R"(usage: run_pipeline --bag IN.bag --output OUT.bag [options]

Runs the dynamic grid, the detector, the grid projection and the fusion on the messages of IN.bag
in time order (no roscore; the same core code and YAML files as the nodelets) and writes the
DetectedObjectArray of every image on /objects of OUT.bag, stamped like the image.

options:
  --bag FILE                input bag (kitti_to_bag or kitti2bag topics by default)
  --output FILE             output bag (written as FILE.tmp, renamed at the end)
  --config-dir DIR          folder of dynamic_grid.yaml, yolo_detector.yaml, grid_projection.yaml,
                            fusion.yaml (default: the package's config/)
  --grid-config FILE        overrides DIR/dynamic_grid.yaml
  --detector-config FILE    overrides DIR/yolo_detector.yaml
  --projection-config FILE  overrides DIR/grid_projection.yaml
  --fusion-config FILE      overrides DIR/fusion.yaml
  --param NODE/KEY=VALUE    sets one parameter on top of the files, as a launch file's <param>
                            (NODE: dynamic_grid, yolo_detector, grid_projection or fusion;
                            VALUE typed as YAML), e.g. --param dynamic_grid/threads=1; repeatable
  --backend NAME            opencv_dnn or replay (default: the detector config's backend)
  --model FILE              Darknet .cfg or .onnx (default: models/yolo/yolov3.cfg of the package)
  --weights FILE            Darknet .weights matching --model
  --class-names FILE        class names (default: models/yolo/coco.names of the package)
  --replay-directory DIR    label files for the replay backend (a drive's label_2)
  --replay-file-pattern P   default %010d.txt (KITTI raw numbering, as kitti_replay.launch)
  --replay-frame-index S    counter or seq (default seq: the frame index kitti_to_bag puts in
                            header.seq, as kitti_replay.launch)
  --topics LIST             input topic names, e.g. points=/velodyne_points,image=/cam/image_raw,
                            camera_info=/cam/camera_info,tf=/tf,tf_static=/tf_static
  --max-tf-wait S           bag seconds a message may wait for its tf (default 0.5)
  --write-grids             also write /grid (DynamicGrid) and /projected_grid (ProjectedGrid)
  --write-detections        also write /detections (Detection2DArray)
  --benchmark               print the median time per frame of every stage, the total, the
                            real-time factor and the memory (peak, and growth after frame 500)
  -q, --quiet               no progress bar
  -h, --help                this text

Exit status: 0 object arrays written; 1 an error naming the file or the option; 3 the bag was read
to its end but no object array came out (the output bag is kept; the reasons are printed: an input
topic without messages, the drops of each stage).
)";

constexpr int kExitNoObjects = 3;

struct Options
{
  std::string bag, output, config_dir;
  std::string grid_config, detector_config, projection_config, fusion_config;
  std::string backend, model, weights, class_names;
  std::string replay_directory, replay_file_pattern = "%010d.txt", replay_frame_index = "seq";
  gvf::PipelineTopics topics;
  std::vector<std::string> params;  ///< --param NODE/KEY=VALUE, in command-line order
  double max_tf_wait = 0.5;
  bool write_grids = false;
  bool write_detections = false;
  bool benchmark = false;
  bool quiet = false;
};

void parseTopics(const std::string& list, gvf::PipelineTopics& topics)
{
  std::size_t begin = 0;
  while (begin <= list.size())
  {
    const std::size_t end = std::min(list.find(',', begin), list.size());
    const std::string item = list.substr(begin, end - begin);
    const std::size_t eq = item.find('=');
    if (eq == std::string::npos || eq + 1 == item.size())
    {
      throw gvf::UsageError("--topics: \"" + item + "\" is not NAME=TOPIC");
    }
    const std::string name = item.substr(0, eq);
    const std::string topic = item.substr(eq + 1);
    if (name == "points")
      topics.points = topic;
    else if (name == "image")
      topics.image = topic;
    else if (name == "camera_info")
      topics.camera_info = topic;
    else if (name == "tf")
      topics.tf = topic;
    else if (name == "tf_static")
      topics.tf_static = topic;
    else
      throw gvf::UsageError("--topics: unknown input \"" + name +
                            "\" (points, image, camera_info, tf, tf_static)");
    begin = end + 1;
  }
}

/// Reads the command line into `o`; false when --help was asked for. @throws gvf::UsageError
bool parseArguments(int argc, char** argv, Options& o)
{
  namespace po = boost::program_options;
  bool help = false;
  std::string topics;
  po::options_description options;
  options.add_options()                                           //
      ("bag", po::value(&o.bag))                                  //
      ("output", po::value(&o.output))                            //
      ("config-dir", po::value(&o.config_dir))                    //
      ("grid-config", po::value(&o.grid_config))                  //
      ("detector-config", po::value(&o.detector_config))          //
      ("projection-config", po::value(&o.projection_config))      //
      ("fusion-config", po::value(&o.fusion_config))              //
      ("param", po::value(&o.params))                             //
      ("backend", po::value(&o.backend))                          //
      ("model", po::value(&o.model))                              //
      ("weights", po::value(&o.weights))                          //
      ("class-names", po::value(&o.class_names))                  //
      ("replay-directory", po::value(&o.replay_directory))        //
      ("replay-file-pattern", po::value(&o.replay_file_pattern))  //
      ("replay-frame-index", po::value(&o.replay_frame_index))    //
      ("topics", po::value(&topics))                              //
      ("max-tf-wait", po::value(&o.max_tf_wait))                  //
      ("write-grids", po::bool_switch(&o.write_grids))            //
      ("write-detections", po::bool_switch(&o.write_detections))  //
      ("benchmark", po::bool_switch(&o.benchmark))                //
      ("quiet,q", po::bool_switch(&o.quiet))                      //
      ("help,h", po::bool_switch(&help));
  const po::variables_map given = gvf::parseCommandLine(argc, argv, options);
  if (help)
  {
    return false;
  }
  if (given.count("topics"))
  {
    parseTopics(topics, o.topics);
  }
  if (!(o.max_tf_wait >= 0.0))
  {
    std::ostringstream value;
    value << o.max_tf_wait;
    throw gvf::UsageError("--max-tf-wait needs seconds >= 0, got " + value.str());
  }
  if (o.bag.empty() || o.output.empty())
  {
    throw gvf::UsageError("--bag and --output are required");
  }
  return true;
}

double medianOf(std::vector<double> values)
{
  if (values.empty())
  {
    return 0.0;
  }
  return gvf::median(values);
}

/// Applies one --param NODE/KEY=VALUE to the source of NODE.
void applyParam(const std::string& param, const std::map<std::string, gvf::YamlParamSource*>& sources)
{
  const std::size_t slash = param.find('/');
  const std::size_t eq = param.find('=');
  if (slash == std::string::npos || eq == std::string::npos || slash > eq || slash + 1 == eq)
  {
    throw std::invalid_argument("--param: \"" + param + "\" is not NODE/KEY=VALUE");
  }
  const auto node = sources.find(param.substr(0, slash));
  if (node == sources.end())
  {
    throw std::invalid_argument("--param: unknown node \"" + param.substr(0, slash) +
                                "\" (dynamic_grid, yolo_detector, grid_projection or fusion)");
  }
  // The value is typed as in a YAML file (5 int, 5.0 double, true bool, text string).
  const gvf::YamlParamSource value =
      gvf::YamlParamSource::fromString("value: " + param.substr(eq + 1), "--param " + param);
  XmlRpc::XmlRpcValue typed;
  if (!value.get("value", typed))
  {
    throw std::invalid_argument("--param: \"" + param + "\" has no value");
  }
  node->second->set(param.substr(slash + 1, eq - slash - 1), typed);
}

/// The configuration of the four stages: the YAML files, what the launch files set on top of
/// them (yolo_detector.launch, kitti_replay.launch), then the --param options. Warns on stderr
/// about unknown and ignored parameters.
gvf::PipelineConfig pipelineConfig(const Options& o)
{
  const std::string config_dir =
      o.config_dir.empty() ? gvf::packagePath("--config-dir") + "/config" : o.config_dir;
  gvf::YamlParamSource grid = gvf::YamlParamSource::fromFile(
      o.grid_config.empty() ? config_dir + "/dynamic_grid.yaml" : o.grid_config);
  gvf::YamlParamSource detector = gvf::YamlParamSource::fromFile(
      o.detector_config.empty() ? config_dir + "/yolo_detector.yaml" : o.detector_config);
  gvf::YamlParamSource projection = gvf::YamlParamSource::fromFile(
      o.projection_config.empty() ? config_dir + "/grid_projection.yaml" : o.projection_config);
  gvf::YamlParamSource fusion =
      gvf::YamlParamSource::fromFile(o.fusion_config.empty() ? config_dir + "/fusion.yaml" : o.fusion_config);
  if (!o.backend.empty())
  {
    detector.set("backend", o.backend);
  }
  std::string backend = "opencv_dnn";
  gvf::readParam(detector, "backend", backend);
  if (backend == "opencv_dnn")
  {
    const std::string model =
        o.model.empty() ? gvf::packagePath("--model") + "/models/yolo/yolov3.cfg" : o.model;
    gvf::checkModelOptions(model, o.weights);
    detector.set("model", model);
    detector.set("weights", o.weights);
    detector.set("class_names", o.class_names.empty()
                                    ? gvf::packagePath("--class-names") + "/models/yolo/coco.names"
                                    : o.class_names);
  }
  detector.set("replay/directory", o.replay_directory);
  detector.set("replay/file_pattern", o.replay_file_pattern);
  detector.set("replay/frame_index", o.replay_frame_index);
  const std::map<std::string, gvf::YamlParamSource*> sources = {{"dynamic_grid", &grid},
                                                                {"yolo_detector", &detector},
                                                                {"grid_projection", &projection},
                                                                {"fusion", &fusion}};
  for (const std::string& param : o.params)
  {
    applyParam(param, sources);
  }

  std::vector<std::string> unknown;
  gvf::PipelineConfig config = gvf::pipelineConfigFromParams(grid, detector, projection, fusion, &unknown);
  config.max_tf_wait = o.max_tf_wait;
  std::vector<std::string> ignored = config.fusion.perFrameOptionsIgnored();
  unknown.insert(unknown.end(), ignored.begin(), ignored.end());
  for (const std::string& warning : unknown)
  {
    std::cerr << "run_pipeline: warning: " << warning << "\n";
  }
  return config;
}

/// The outputs of the pipeline, written into `out`: /objects, and what the options add.
gvf::PipelineOutputs outputsInto(rosbag::Bag& out, const Options& o)
{
  gvf::PipelineOutputs outputs;
  outputs.objects = [&out](const gvf::DetectedObjectArray::ConstPtr& m)
  { out.write("/objects", m->header.stamp, m); };
  if (o.write_grids)
  {
    outputs.grid = [&out](const gvf::DynamicGrid::ConstPtr& m) { out.write("/grid", m->header.stamp, m); };
    outputs.projected_grid = [&out](const gvf::ProjectedGrid::ConstPtr& m)
    { out.write("/projected_grid", m->header.stamp, m); };
  }
  if (o.write_detections)
  {
    outputs.detections = [&out](const gvf::Detection2DArray::ConstPtr& m)
    { out.write("/detections", m->header.stamp, m); };
  }
  return outputs;
}

/// Runs `pipeline` over the bag, with a progress bar on stderr unless --quiet.
gvf::BagRunSummary runWithProgress(gvf::Pipeline& pipeline, const Options& o)
{
  const bool tty = isatty(STDERR_FILENO) != 0;
  std::unique_ptr<gvf::ProgressBar> bar;
  const gvf::BagRunSummary summary =
      gvf::runPipelineOnBag(pipeline, o.bag, o.topics,
                            [&](std::size_t done, std::size_t total)
                            {
                              if (o.quiet)
                              {
                                return;
                              }
                              if (!bar)
                              {
                                bar = std::make_unique<gvf::ProgressBar>(std::cerr, total, "messages", tty);
                              }
                              bar->update(done);
                            });
  if (bar)
  {
    bar->finish();
  }
  return summary;
}

/// On stderr: the messages read and written, the drops and their reasons, and, when no object
/// array came out, which input was missing.
void printStats(const gvf::PipelineStats& s, const gvf::BagRunSummary& summary, const Options& o)
{
  std::cerr << "run_pipeline: " << summary.messages_read << " messages, " << s.clouds << " clouds, "
            << s.images << " images, " << s.camera_infos << " camera_infos -> " << s.grids << " grids, "
            << s.projections << " projected grids, " << s.objects << " object arrays on /objects\n";
  const std::size_t drops =
      s.grid_drops + s.detector_drops + s.projection_drops + s.fusion_drops + s.grid_resets;
  if (drops > 0)
  {
    std::cerr << "run_pipeline: dropped: " << s.grid_drops << " scans, " << s.detector_drops << " images, "
              << s.projection_drops << " camera_infos, " << s.fusion_drops << " fusion inputs; "
              << s.grid_resets << " grid resets.\n";
  }
  if (s.projections_without_cells > 0)
  {
    std::cerr << "run_pipeline: " << s.projections_without_cells
              << " projected grids without cells (the grid too old for the image): their detections came out "
                 "placed by their boxes or tracks, motion unknown.\n";
  }
  if (drops + s.projections_without_cells > 0)
  {
    std::cerr << "run_pipeline: reasons:\n";
    for (const std::string& w : s.warnings)
    {
      std::cerr << "  " << w << "\n";
    }
  }
  if (s.objects == 0)
  {
    std::cerr << "run_pipeline: error: no object array came out of " << o.bag << " (" << o.output
              << " holds no /objects)";
    for (const auto& [count, topic, what] :
         {std::tuple{s.clouds, o.topics.points, "point cloud"}, std::tuple{s.images, o.topics.image, "image"},
          std::tuple{s.camera_infos, o.topics.camera_info, "camera_info"}})
    {
      if (count == 0)
      {
        std::cerr << "; no " << what << " on " << topic << " (--topics names another)";
      }
    }
    std::cerr << (s.warnings.empty() ? "\n" : "; the reasons above\n");
  }
}

/// --benchmark on stdout: the median time per frame of every stage, the total, the real-time
/// factor and the memory.
void printBenchmark(const gvf::PipelineStats& s, const gvf::BagRunSummary& summary,
                    const std::string& backend)
{
  const double grid = medianOf(s.grid_ms);
  const double det = medianOf(s.detector_ms);
  const double proj = medianOf(s.projection_ms);
  const double fus = medianOf(s.fusion_ms);
  const double frames = static_cast<double>(std::max<std::size_t>(summary.frames, 1));
  const double wall_per_frame = 1e3 * summary.wall_s / frames;
  std::printf("benchmark on %s\n", gvf::machineInfo().describe().c_str());
  std::printf("benchmark: %zu frames, bag %.1f s, wall %.1f s\n", summary.frames, summary.bag_duration_s,
              summary.wall_s);
  std::printf(
      "  median per frame [ms]: dynamic_grid %.2f, detector (%s) %.2f, grid_projection %.2f, "
      "fusion %.3f, sum %.2f\n",
      grid, backend.c_str(), det, proj, fus, grid + det + proj + fus);
  std::printf("  wall per frame (reading, all stages, writing): %.2f ms, %.1f frames/s, %.2fx real time\n",
              wall_per_frame, 1e3 / wall_per_frame,
              summary.wall_s > 0 ? summary.bag_duration_s / summary.wall_s : 0.0);
  std::printf("  memory: peak %.1f MiB (getrusage)", gvf::peakResidentMemoryMiB());
  if (summary.rss_mb.size() > 500)
  {
    const double at500 = summary.rss_mb[499];
    const double end = summary.rss_mb.back();
    std::printf(", resident at frame 500 %.1f MiB, at the end (frame %zu) %.1f MiB, growth %+.2f %%", at500,
                summary.rss_mb.size(), end, 100.0 * (end - at500) / at500);
  }
  std::printf("\n");
}

int run(const Options& o)
{
  const gvf::PipelineConfig config = pipelineConfig(o);
  // Written as OUTPUT.tmp, moved to OUTPUT when complete; removed on any failure.
  gvf::TemporaryOutput output(o.output);
  rosbag::Bag out;
  try
  {
    out.open(output.temporary(), rosbag::bagmode::Write);
  }
  catch (const rosbag::BagException& e)
  {
    throw std::runtime_error("cannot write the output bag " + o.output + ": " + e.what());
  }
  gvf::Pipeline pipeline(config, outputsInto(out, o));
  for (const std::string& warning : pipeline.detectorWarnings())
  {
    std::cerr << "run_pipeline: detector: " << warning << "\n";
  }
  std::cerr << "run_pipeline: " << o.bag << " -> " << o.output << " (detector " << config.detector.backend
            << ")\n";
  const gvf::BagRunSummary summary = runWithProgress(pipeline, o);
  try
  {
    out.close();
  }
  catch (const rosbag::BagException& e)
  {
    throw std::runtime_error("cannot finish the output bag " + o.output + ": " + e.what());
  }
  output.commit();

  const gvf::PipelineStats& s = pipeline.stats();
  printStats(s, summary, o);
  if (o.benchmark)
  {
    printBenchmark(s, summary, config.detector.backend);
  }
  return s.objects > 0 ? 0 : kExitNoObjects;
}
}  // namespace

int main(int argc, char** argv)
{
  Options o;
  if (const auto status =
          gvf::readCommandLine("run_pipeline", kUsage, 1, [&] { return parseArguments(argc, argv, o); }))
  {
    return *status;
  }
  try
  {
    return run(o);
  }
  catch (const std::exception& e)
  {
    std::cerr << "run_pipeline: " << e.what() << "\n";
    return 1;
  }
}
