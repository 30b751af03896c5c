// detect: a YOLO network (OpenCV DNN: a Darknet cfg + weights or an ONNX model) run once over
// images, its detections written as KITTI object result files, one per image, that the replay
// backend reads back: the slow network runs once, its detections replay many times
// (run_pipeline --backend replay, kitti_replay.launch replay_directory:=). See doc/tools/detect.md.
//
//   rosrun grid_vision_fusion detect --model M [options] --output DIR IMAGES...
#include <unistd.h>

#include <opencv2/imgcodecs.hpp>

#include <algorithm>
#include <cctype>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "grid_vision_fusion/cli/command_line.h"
#include "grid_vision_fusion/cli/machine_info.h"
#include "grid_vision_fusion/cli/model_options.h"
#include "grid_vision_fusion/cli/package_path.h"
#include "grid_vision_fusion/cli/progress_bar.h"
#include "grid_vision_fusion/detection/kitti_results.h"
#include "grid_vision_fusion/detection/yolo_detector.h"
#include "grid_vision_fusion/ros/node_params.h"

namespace gvf = grid_vision_fusion;
namespace fs = std::filesystem;

namespace
{
constexpr int kExitFailure = 1;
constexpr int kExitUsage = 2;
/// Score threshold of the files written unless --score-threshold says otherwise.
constexpr double kDefaultWriteThreshold = 0.25;

const char* const kUsage = R"(usage: detect --model FILE --output DIR [options] IMAGES...

Runs a YOLO network (OpenCV DNN) on every image and writes one KITTI object result file per image,
DIR/<image name>.txt (000123.png -> 000123.txt): the 2-D box, the type and the score (16th column);
the 3-D fields hold KITTI's "unknown" values. The replay backend reads them back
(run_pipeline --backend replay --replay-directory DIR, kitti_replay.launch replay_directory:=DIR).

IMAGES are image files, folders of images (sorted by name), KITTI raw drive folders (their
image_02/data) or KITTI object folders (their image_2).

options:
  --model FILE            Darknet .cfg or .onnx model (required)
  --weights FILE          Darknet .weights matching --model (none for ONNX)
  --class-names FILE      class names, one per line (default: the package's models/yolo/coco.names)
  --config FILE           detector parameters as config/yolo_detector.yaml: input size, resize mode,
                          NMS, class_map, DNN backend (default: the package's config/yolo_detector.yaml)
  --input WxH             network input size, e.g. 416x416 for a Darknet cfg (overrides the config's;
                          default: the model's own, the cfg's [net] size or the input an ONNX file
                          declares, which is the only size such a model runs at)
  --score-threshold S     lowest score written, [0, 1] (default 0.25, below the nodelet's 0.5: the
                          replay's score_threshold filters when the files are read)
  --nms N                 IoU of per-class non-maximum suppression, [0, 1] (default: the config's)
  --class-map LIST        model class -> written type, e.g. car=Car,person=Pedestrian; other classes
                          are not written (default: the config's class_map)
  --all-classes           write every class of the model under its own name (riders not merged)
  --output DIR            folder of the label files (created; files of the same name are replaced)
  --overlay               also write DIR/overlay/<image name>.png: the boxes with type and score
  -q, --quiet             no progress bar
  -h, --help              this text

A type is written as the KITTI type it names ignoring case (car -> Car, pedestrian -> Pedestrian),
any other name with spaces as '_'. Exit status: 0 every image done; 1 an error naming the file
(model, config, input, output), or images that could not be read (skipped with a warning, no label
file written for them, the others done); 2 a usage error.
)";

using gvf::UsageError;

struct Options
{
  std::string model, weights, class_names, config, output;
  std::optional<cv::Size> input;
  std::optional<double> score_threshold, nms;
  std::optional<std::map<std::string, std::string>> class_map;
  bool all_classes = false;  ///< also no rider merging
  bool overlay = false;
  bool quiet = false;
  std::vector<std::string> images;
};

cv::Size parseInputSize(const std::string& text)
{
  int width = 0, height = 0;
  char end = 0;
  if (std::sscanf(text.c_str(), "%dx%d%c", &width, &height, &end) != 2 || width <= 0 || height <= 0 ||
      width > 4096 || height > 4096)
  {
    throw UsageError("--input wants WxH with both in [1, 4096], e.g. 640x192, got \"" + text + "\"");
  }
  return {width, height};
}

/// `value` of `option` if it lies in [0, 1]. @throws UsageError
double checkFraction(const std::string& option, double value)
{
  if (!(value >= 0.0 && value <= 1.0))
  {
    std::ostringstream text;
    text << value;
    throw UsageError(option + " wants a number in [0, 1], got " + text.str());
  }
  return value;
}

std::map<std::string, std::string> parseClassMap(const std::string& text)
{
  std::map<std::string, std::string> map;
  std::size_t begin = 0;
  while (begin <= text.size())
  {
    const std::size_t end = std::min(text.find(',', begin), text.size());
    const std::string item = text.substr(begin, end - begin);
    const std::size_t eq = item.find('=');
    if (eq == std::string::npos || eq == 0 || eq + 1 == item.size())
    {
      throw UsageError("--class-map: \"" + item + "\" is not MODEL_CLASS=TYPE");
    }
    map[item.substr(0, eq)] = item.substr(eq + 1);
    begin = end + 1;
  }
  return map;
}

/// The checks of the options together: required ones, the model files, exclusions.
/// @throws UsageError
void checkArguments(Options& o)
{
  if (o.model.empty())
  {
    throw UsageError("--model is required");
  }
  try
  {
    gvf::checkModelOptions(o.model, o.weights);
  }
  catch (const std::invalid_argument& e)
  {
    throw UsageError(e.what());
  }
  if (o.output.empty())
  {
    throw UsageError("--output is required");
  }
  if (o.images.empty())
  {
    throw UsageError("no IMAGES given");
  }
  if (o.all_classes && o.class_map)
  {
    throw UsageError("--class-map and --all-classes exclude each other");
  }
  if (o.all_classes)
  {
    o.class_map.emplace();
  }
}

/// Parses the command line; false when --help was asked for.
bool parseArguments(int argc, char** argv, Options& o)
{
  namespace po = boost::program_options;
  bool help = false;
  po::options_description options;
  options.add_options()                                 //
      ("model", po::value(&o.model))                    //
      ("weights", po::value(&o.weights))                //
      ("class-names", po::value(&o.class_names))        //
      ("config", po::value(&o.config))                  //
      ("input", po::value<std::string>())               //
      ("score-threshold", po::value<double>())          //
      ("nms", po::value<double>())                      //
      ("class-map", po::value<std::string>())           //
      ("all-classes", po::bool_switch(&o.all_classes))  //
      ("output", po::value(&o.output))                  //
      ("overlay", po::bool_switch(&o.overlay))          //
      ("quiet,q", po::bool_switch(&o.quiet))            //
      ("help,h", po::bool_switch(&help));
  const po::variables_map given = gvf::parseCommandLine(argc, argv, options, &o.images);
  if (help)
  {
    return false;
  }
  if (given.count("input"))
  {
    o.input = parseInputSize(given["input"].as<std::string>());
  }
  if (given.count("score-threshold"))
  {
    o.score_threshold = checkFraction("--score-threshold", given["score-threshold"].as<double>());
  }
  if (given.count("nms"))
  {
    o.nms = checkFraction("--nms", given["nms"].as<double>());
  }
  if (given.count("class-map"))
  {
    o.class_map = parseClassMap(given["class-map"].as<std::string>());
  }
  checkArguments(o);
  return true;
}

bool isImageFile(const fs::path& path)
{
  std::string extension = path.extension().string();
  std::transform(extension.begin(), extension.end(), extension.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  static const std::set<std::string> kExtensions{".png", ".jpg", ".jpeg", ".bmp",  ".ppm",
                                                 ".pgm", ".pnm", ".tif",  ".tiff", ".webp"};
  return kExtensions.count(extension) > 0;
}

/// The folder of images a folder argument stands for: a KITTI raw drive's image_02/data, a
/// KITTI object folder's image_2, or the folder itself.
fs::path imageFolderOf(const fs::path& folder)
{
  std::error_code error;
  for (const fs::path& inner : {folder / "image_02" / "data", folder / "image_2"})
  {
    if (fs::is_directory(inner, error))
    {
      return inner;
    }
  }
  return folder;
}

/// The images of the IMAGES arguments, in order (each folder's sorted by name).
/// @throws std::runtime_error naming an argument that does not exist or a folder without images;
///         UsageError when two images would write the same label file.
std::vector<fs::path> listImages(const std::vector<std::string>& arguments)
{
  std::vector<fs::path> images;
  for (const std::string& argument : arguments)
  {
    std::error_code error;
    const fs::path path(argument);
    if (fs::is_directory(path, error))
    {
      const fs::path folder = imageFolderOf(path);
      std::vector<fs::path> found;
      for (const fs::directory_entry& entry : fs::directory_iterator(folder))
      {
        if (entry.is_regular_file(error) && isImageFile(entry.path()))
        {
          found.push_back(entry.path());
        }
      }
      if (found.empty())
      {
        throw std::runtime_error(folder.string() + ": no image (.png, .jpg, .jpeg, .bmp, .ppm, .pgm, .pnm, " +
                                 ".tif, .tiff, .webp) in this folder");
      }
      std::sort(found.begin(), found.end());
      images.insert(images.end(), found.begin(), found.end());
    }
    else if (fs::exists(path, error))
    {
      images.push_back(path);
    }
    else
    {
      throw std::runtime_error(argument + ": no such file or folder");
    }
  }
  std::map<std::string, fs::path> by_name;
  for (const fs::path& image : images)
  {
    const auto [entry, added] = by_name.emplace(image.stem().string(), image);
    if (!added)
    {
      throw UsageError("two images would write the same label file " + image.stem().string() +
                       ".txt: " + entry->second.string() + " and " + image.string());
    }
  }
  return images;
}

/// The replay file_pattern that names every label file from its frame index ("%06d.txt"), or
/// empty when the names are not all numbers of one width.
std::string replayPatternOf(const std::vector<fs::path>& images)
{
  std::size_t width = 0;
  for (const fs::path& image : images)
  {
    const std::string stem = image.stem().string();
    if (stem.empty() ||
        !std::all_of(stem.begin(), stem.end(), [](unsigned char c) { return std::isdigit(c); }) ||
        (width != 0 && stem.size() != width))
    {
      return "";
    }
    width = stem.size();
  }
  return "%0" + std::to_string(width) + "d.txt";
}

double medianOf(std::vector<double> values)
{
  if (values.empty())
  {
    return 0.0;
  }
  const auto middle = values.begin() + static_cast<std::ptrdiff_t>(values.size() / 2);
  std::nth_element(values.begin(), middle, values.end());
  if (values.size() % 2 == 1)
  {
    return *middle;
  }
  return 0.5 * (*middle + *std::max_element(values.begin(), middle));
}

/// The detector configuration: the config file, the model files, then the options on top.
gvf::YoloDetectorConfig detectorConfig(const Options& o)
{
  const std::string config_path =
      o.config.empty() ? gvf::packagePath("--config") + "/config/yolo_detector.yaml" : o.config;
  gvf::YamlParamSource source = gvf::YamlParamSource::fromFile(config_path);
  source.set("backend", std::string("opencv_dnn"));
  source.set("model", o.model);
  source.set("weights", o.weights);
  source.set("class_names", o.class_names.empty()
                                ? gvf::packagePath("--class-names") + "/models/yolo/coco.names"
                                : o.class_names);
  if (o.input)
  {
    source.set("input_width", o.input->width);
    source.set("input_height", o.input->height);
  }
  std::vector<std::string> unknown;
  gvf::YoloDetectorConfig config = gvf::DetectorParams::fromParams(source, &unknown).yolo;
  for (const std::string& warning : unknown)
  {
    std::cerr << "detect: warning: " << warning << "\n";
  }
  config.score_threshold = o.score_threshold.value_or(kDefaultWriteThreshold);
  if (o.nms)
  {
    config.nms_threshold = *o.nms;
  }
  if (o.class_map)
  {
    config.class_map = *o.class_map;
  }
  if (o.all_classes)
  {
    config.rider_merge.clear();
  }
  config.validate();
  return config;
}

/// What the run did, for the summary.
struct RunSummary
{
  std::map<std::string, std::size_t> per_type;  ///< detections written by KITTI type
  std::vector<std::string> unreadable;          ///< images that could not be read
  std::vector<double> detect_ms;                ///< detector time of each image done [ms]
  std::size_t detections = 0;
  double wall_s = 0.0;
};

/// Detects the objects of `image` and writes its label file (and overlay) into `output`.
void detectImage(gvf::YoloDetector& detector, const cv::Mat& image, const fs::path& image_path,
                 const fs::path& output, bool overlay, RunSummary& summary)
{
  const auto before = std::chrono::steady_clock::now();
  std::vector<gvf::Detection> detections = detector.detect(image, gvf::PixelFormat::kBgr8);
  summary.detect_ms.push_back(
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - before).count());
  std::vector<gvf::KittiObjectLabel> labels;
  for (gvf::Detection& detection : detections)
  {
    labels.push_back(gvf::kittiResultOf(detection));
    detection.label = labels.back().type;
    ++summary.per_type[detection.label];
  }
  summary.detections += labels.size();
  gvf::writeKittiLabels((output / (image_path.stem().string() + ".txt")).string(), labels);
  if (overlay)
  {
    cv::Mat drawn = image.clone();
    gvf::drawDetections(drawn, detections);
    const fs::path overlay_path = output / "overlay" / (image_path.stem().string() + ".png");
    if (!cv::imwrite(overlay_path.string(), drawn))
    {
      throw std::runtime_error(overlay_path.string() + ": cannot write the overlay image");
    }
  }
}

/// The summary on stdout: images, detections per type, time per image, the replay options.
void printSummary(const RunSummary& summary, const std::vector<fs::path>& images, const fs::path& output,
                  double score_threshold)
{
  const std::size_t done = images.size() - summary.unreadable.size();
  std::printf("detect: %zu of %zu images, %zu detections (score >= %g) in %.1f s on %s\n", done,
              images.size(), summary.detections, score_threshold, summary.wall_s,
              gvf::machineInfo().describe().c_str());
  if (done > 0)
  {
    double sum = 0.0;
    for (double ms : summary.detect_ms)
    {
      sum += ms;
    }
    std::printf(
        "  per image: detector median %.1f ms, mean %.1f ms (letterbox, network, decoding, NMS); "
        "wall %.1f ms (reading and writing included)\n",
        medianOf(summary.detect_ms), sum / static_cast<double>(done),
        1e3 * summary.wall_s / static_cast<double>(done));
  }
  std::printf("  per type:");
  for (const auto& [type, count] : summary.per_type)
  {
    std::printf(" %s %zu", type.c_str(), count);
  }
  std::printf("%s\n", summary.per_type.empty() ? " none" : "");
  std::printf("  label files in %s", output.string().c_str());
  const std::string pattern = replayPatternOf(images);
  if (!pattern.empty())
  {
    std::printf(" (replay: --replay-directory %s --replay-file-pattern %s)", output.string().c_str(),
                pattern.c_str());
  }
  std::printf("\n");
}

int run(const Options& o)
{
  const std::vector<fs::path> images = listImages(o.images);
  const gvf::YoloDetectorConfig config = detectorConfig(o);
  const std::unique_ptr<gvf::YoloDetector> detector = std::make_unique<gvf::YoloDetector>(config);
  for (const std::string& warning : detector->warnings())
  {
    std::cerr << "detect: warning: " << warning << "\n";
  }
  const fs::path output(o.output);
  const fs::path created = o.overlay ? output / "overlay" : output;
  std::error_code error;
  fs::create_directories(created, error);
  if (error)
  {
    throw std::runtime_error("cannot create the output folder " + created.string() + ": " + error.message());
  }
  std::cerr << "detect: " << images.size() << " images, " << detector->description()
            << ", score >= " << config.score_threshold << " -> " << output.string() << "\n";

  RunSummary summary;
  const bool interactive = isatty(STDERR_FILENO) != 0;
  gvf::ProgressBar bar(std::cerr, images.size(), "images", interactive);
  const auto start = std::chrono::steady_clock::now();
  for (std::size_t i = 0; i < images.size(); ++i)
  {
    if (!o.quiet)
    {
      bar.update(i);
    }
    const cv::Mat image = cv::imread(images[i].string(), cv::IMREAD_COLOR);
    if (image.empty())
    {
      std::cerr << (interactive && !o.quiet ? "\n" : "") << "detect: warning: " << images[i].string()
                << ": cannot read the image (skipped, no label file written)\n";
      summary.unreadable.push_back(images[i].string());
      continue;
    }
    detectImage(*detector, image, images[i], output, o.overlay, summary);
  }
  if (!o.quiet)
  {
    bar.update(images.size());
    bar.finish();
  }
  summary.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  printSummary(summary, images, output, config.score_threshold);
  if (!summary.unreadable.empty())
  {
    std::cerr << "detect: " << summary.unreadable.size()
              << " image(s) could not be read, no label file written for "
              << (summary.unreadable.size() == 1 ? "it" : "them") << ": " << summary.unreadable.front()
              << (summary.unreadable.size() > 1 ? ", ..." : "") << "\n";
    return kExitFailure;
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv)
{
  Options options;
  try
  {
    if (!parseArguments(argc, argv, options))
    {
      std::cout << kUsage;
      return 0;
    }
    return run(options);
  }
  catch (const UsageError& e)
  {
    return gvf::usageFailure("detect", e.what(), kUsage, kExitUsage);
  }
  catch (const std::exception& e)
  {
    std::cerr << "detect: error: " << e.what() << "\n";
    return kExitFailure;
  }
}
