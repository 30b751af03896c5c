// Inference time of YOLO networks through YoloDetector (preprocessing, OpenCV DNN forward pass,
// decoding, NMS) on a KITTI-sized image: by default the real YOLOv3 (416, 608) and YOLOv3-tiny
// (416) architectures of models/yolo with random weights written in the Darknet format to a
// temporary directory (speed does not depend on training). Reports ms per frame, achieved GFLOP/s
// (cv::dnn::Net::getFLOPS / time) and the machine's peak.
//
// The 3 × 3 stride-1 convolutions run two ways: by OpenCV's own convolution, as the detector runs
// them, and by oneDNN (bench/onednn_convolution.h, names ending in "/onednn"; only where CMake
// found libdnnl-dev, otherwise the output says so and skips them). Before timing, the network
// outputs of the oneDNN variant are compared with OpenCV's on the benchmark image (printed; a
// relative difference above 1e-3 is an error). The FLOP bound is the direct convolution's in
// both. (Until issue 44 a third variant, the detector's own Winograd layer, ran as well:
// doc/decisions/0027-winograd-layer.md.)
//
// Run: devel/lib/grid_vision_fusion/bench_yolo [--benchmark_filter=tiny]
//      devel/lib/grid_vision_fusion/bench_yolo --write-weights DIR   (writes yolov3-tiny.weights
//      and yolov3.weights with these random values into DIR and exits: for run_pipeline
//      --benchmark with a real network architecture)
//      devel/lib/grid_vision_fusion/bench_yolo --profile [yolov3-416|yolov3-tiny-416|yolov3-608]
//      [--onednn]
//      (per layer type: time from cv::dnn::Net::getPerfProfile, FLOPs, achieved GFLOP/s and the
//      share of the frame; convolutions also by kernel size: where the time beyond the FLOP
//      bound goes)
//      devel/lib/grid_vision_fusion/bench_yolo --model M.onnx --input 640x192 [--model M2 --input WxH
//      ...] [--weights W] [--class-names N] [--image FILE] [--iterations N] [--onednn]
//      [--benchmark_repetitions=5 --benchmark_enable_random_interleaving=true]
//      (other models, e.g. those of scripts/fetch_model.sh: each --model with the --input (and
//      --weights for a Darknet cfg; without them, random weights) that follow it; several in one
//      run for figures taken under the same load; --onednn adds that variant of every model; on
//      --image, a KITTI frame, or on a random image of KITTI's size)
#include <benchmark/benchmark.h>

#include <opencv2/core.hpp>
#include <opencv2/core/utility.hpp>
#include <opencv2/dnn.hpp>
#include <opencv2/dnn/all_layers.hpp>
#include <opencv2/imgcodecs.hpp>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <optional>
#include <random>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include <unistd.h>

#include "grid_vision_fusion/cli/machine_info.h"
#include "grid_vision_fusion/detection/yolo_detector.h"
#include "onednn_convolution.h"

namespace
{
using namespace grid_vision_fusion;

const std::string kCfgDir = GVF_YOLO_CFG_DIR;

/// Writes Darknet weights for `cfg_path` with He-initialised random kernels, zero biases and
/// identity batch normalisation (activations stay in a normal floating-point range).
std::string writeRandomWeights(const std::string& cfg_path, const std::string& directory)
{
  const DarknetCfgInfo info = parseDarknetCfg(cfg_path);
  const std::string path = directory + "/" + std::filesystem::path(cfg_path).stem().string() + ".weights";
  std::ofstream out(path, std::ios::binary);
  const std::int32_t version[3] = {0, 2, 0};
  const std::uint64_t seen = 0;
  out.write(reinterpret_cast<const char*>(version), sizeof(version));
  out.write(reinterpret_cast<const char*>(&seen), sizeof(seen));
  std::mt19937 random(42);
  auto write = [&out](const std::vector<float>& values)
  {
    out.write(reinterpret_cast<const char*>(values.data()),
              static_cast<std::streamsize>(values.size() * sizeof(float)));
  };
  for (const DarknetParamBlock& block : info.blocks)
  {
    const std::size_t n = static_cast<std::size_t>(block.outputs);
    write(std::vector<float>(n, 0.F));
    if (block.batch_normalize)
    {
      write(std::vector<float>(n, 1.F));
      write(std::vector<float>(n, 0.F));
      write(std::vector<float>(n, 1.F));
    }
    const double fan_in = static_cast<double>(block.weights) / static_cast<double>(n);
    std::uniform_real_distribution<float> kernel(-static_cast<float>(std::sqrt(6.0 / fan_in)),
                                                 static_cast<float>(std::sqrt(6.0 / fan_in)));
    std::vector<float> weights(block.weights);
    for (float& w : weights)
    {
      w = kernel(random);
    }
    write(weights);
  }
  if (!out)
  {
    throw std::runtime_error("cannot write " + path);
  }
  return path;
}

double processCpuSeconds()
{
  timespec t{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

/// Which layer computes the 3 × 3 stride-1 convolutions.
enum class Conv
{
  kOpenCv,  ///< OpenCV's own convolution, as the detector runs it
  kOnednn,  ///< oneDNN (bench/onednn_convolution.h)
};

/// The suffix of a variant's benchmark name.
std::string suffix(Conv conv)
{
  return conv == Conv::kOnednn ? "/onednn" : "";
}

/// While alive, networks built and first run compute their 3 × 3 stride-1 convolutions by `conv`.
class ConvolutionScope
{
public:
  explicit ConvolutionScope(Conv conv)
  {
    if (conv == Conv::kOnednn)
    {
      onednn_.emplace();
    }
  }

private:
  std::optional<bench::OnednnConvolutionScope> onednn_;
};

/// A detector whose 3 × 3 stride-1 convolutions are computed by `conv`.
std::shared_ptr<YoloDetector> makeDetector(YoloDetectorConfig config, Conv conv)
{
  const ConvolutionScope scope(conv);  // OpenCV creates the layers in the constructor's forward pass
  return std::make_shared<YoloDetector>(config);
}

/// A network of the default set: a Darknet cfg of models/yolo with random weights.
struct Model
{
  std::string name;
  std::string cfg;
  int input = 0;
  int iterations = 0;
  Conv conv = Conv::kOpenCv;
};

/// A random image of KITTI's size (1242 × 375), or the image at `path`.
cv::Mat benchmarkImage(const std::string& path)
{
  if (!path.empty())
  {
    cv::Mat image = cv::imread(path, cv::IMREAD_COLOR);
    if (image.empty())
    {
      throw std::runtime_error(path + ": cannot read the image");
    }
    return image;
  }
  cv::Mat image(375, 1242, CV_8UC3);
  cv::randu(image, cv::Scalar::all(0), cv::Scalar::all(255));
  return image;
}

void benchmarkDetector(benchmark::State& state, YoloDetector& detector, const cv::Mat& image,
                       const MachineInfo& peak)
{
  detector.detect(image, PixelFormat::kBgr8);  // second warm-up, at the benchmark's image size
  const double cpu_start = processCpuSeconds();
  for (auto _ : state)
  {
    benchmark::DoNotOptimize(detector.detect(image, PixelFormat::kBgr8));
  }
  // CPU time of all threads per frame: on a shared machine the wall time includes waiting for
  // the cores; this divided by the cores is the time on dedicated cores (perfect scaling).
  const double cpu_ms = (processCpuSeconds() - cpu_start) * 1e3 / static_cast<double>(state.iterations());
  state.counters["cpu_ms_all_threads"] = cpu_ms;
  const double flops = static_cast<double>(detector.flops());
  state.counters["net_GFLOP"] = flops / 1e9;
  // A rate counter is divided by the measured (real) time: achieved GFLOP per second.
  state.counters["achieved_GFLOP"] =
      benchmark::Counter(flops / 1e9 * static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
  state.counters["peak_GFLOPs"] = peak.peakGflops();
  state.counters["FLOP_bound_ms"] = flops / (peak.peakGflops() * 1e9) * 1e3;
}

/// Time and FLOPs of one group of layers over the profiled frames.
struct LayerGroup
{
  int layers = 0;
  double ms = 0.0;     ///< per frame
  double flops = 0.0;  ///< per frame
};

/// --profile: the forward pass of `model` layer by layer (cv::dnn::Net::getPerfProfile, the
/// OpenCV backend on the CPU with the detector's thread count), grouped by layer type and, for
/// the convolutions, by kernel size and stride. Prints the tables; returns the process status.
int profileModel(const Model& model, const std::string& weights, const MachineInfo& peak, int frames)
{
  cv::Mat image(model.input, model.input, CV_8UC3);
  cv::randu(image, cv::Scalar::all(0), cv::Scalar::all(255));
  const cv::Mat blob =
      cv::dnn::blobFromImage(image, 1.0 / 255.0, cv::Size(), cv::Scalar(), true, false, CV_32F);
  std::vector<cv::Mat> outputs;
  cv::dnn::Net net;
  {
    const ConvolutionScope scope(model.conv);  // until the layers exist
    net = cv::dnn::readNetFromDarknet(kCfgDir + "/" + model.cfg, weights);
    net.setPreferableBackend(cv::dnn::DNN_BACKEND_OPENCV);
    net.setPreferableTarget(cv::dnn::DNN_TARGET_CPU);
    net.setInput(blob);
    net.forward(outputs, net.getUnconnectedOutLayersNames());  // warm-up: allocations, layer fusion
  }
  const cv::dnn::MatShape shape{1, 3, model.input, model.input};
  const std::vector<std::string> names = net.getLayerNames();
  std::vector<double> layer_ms(names.size(), 0.0);
  double total_ms = 0.0;
  for (int f = 0; f < frames; ++f)
  {
    net.setInput(blob);
    net.forward(outputs, net.getUnconnectedOutLayersNames());
    std::vector<double> timings;
    total_ms += static_cast<double>(net.getPerfProfile(timings)) * 1e3 / cv::getTickFrequency();
    for (std::size_t i = 0; i < timings.size() && i < layer_ms.size(); ++i)
    {
      layer_ms[i] += timings[i] * 1e3 / cv::getTickFrequency();
    }
  }
  std::map<std::string, LayerGroup> by_type, by_kernel;
  double total_flops = 0.0;
  for (std::size_t i = 0; i < names.size(); ++i)
  {
    const int id = net.getLayerId(names[i]);
    const cv::Ptr<cv::dnn::Layer> layer = net.getLayer(id);
    const double ms = layer_ms[i] / frames;
    const double flops = static_cast<double>(net.getFLOPS(id, shape));
    total_flops += flops;
    LayerGroup& type = by_type[layer->type];
    ++type.layers;
    type.ms += ms;
    type.flops += flops;
    if (layer->type == bench::kOnednnLayerType)
    {
      LayerGroup& group = by_kernel["3x3 (oneDNN)"];
      ++group.layers;
      group.ms += ms;
      group.flops += flops;
    }
    else if (layer->type == "Convolution" && !layer->blobs.empty() && layer->blobs[0].dims == 4)
    {
      const auto* conv = dynamic_cast<const cv::dnn::ConvolutionLayer*>(layer.get());
      const cv::MatSize kernel = layer->blobs[0].size;
      std::string key = std::to_string(kernel[2]) + "x" + std::to_string(kernel[3]);
      if (conv != nullptr && (conv->strides.empty() ? 1 : conv->strides[0]) > 1)
      {
        key += " stride " + std::to_string(conv->strides[0]);
      }
      LayerGroup& group = by_kernel[key];
      ++group.layers;
      group.ms += ms;
      group.flops += flops;
    }
  }
  total_ms /= frames;
  const double bound_ms = total_flops / (peak.peakGflops() * 1e9) * 1e3;
  std::printf(
      "%s: %d frames, %.1f ms per frame (forward pass, getPerfProfile), %.2f GFLOP, FLOP bound %.1f ms "
      "at %.1f GFLOP/s peak: %.2f x the bound\n",
      model.name.c_str(), frames, total_ms, total_flops / 1e9, bound_ms, peak.peakGflops(),
      total_ms / bound_ms);
  auto print = [&](const char* title, const std::map<std::string, LayerGroup>& groups)
  {
    std::printf(
        "\n| %s | layers | ms / frame | share | GFLOP | achieved GFLOP/s | %% of peak | ms beyond its bound "
        "|\n"
        "|---|---|---|---|---|---|---|---|\n",
        title);
    for (const auto& [name, g] : groups)
    {
      const double rate = g.ms > 0.0 ? g.flops / (g.ms * 1e6) : 0.0;
      std::printf("| %s | %d | %.1f | %.1f %% | %.2f | %.1f | %.0f %% | %.1f |\n", name.c_str(), g.layers,
                  g.ms, 100.0 * g.ms / total_ms, g.flops / 1e9, rate, 100.0 * rate / peak.peakGflops(),
                  g.ms - g.flops / (peak.peakGflops() * 1e6));
    }
  };
  print("layer type", by_type);
  print("convolution kernel", by_kernel);
  return 0;
}

/// A network to time: one of the default set, or one given by --model.
struct TrainedModel
{
  std::string model;    ///< ONNX file or Darknet cfg
  std::string weights;  ///< Darknet weights; empty for a cfg: random ones (writeRandomWeights)
  int width = 0;        ///< 0: the model's own input size
  int height = 0;
  std::string name;    ///< benchmark name; empty: "<file>@<W>x<H>"
  int iterations = 0;  ///< 0: Options::iterations
  /// 0.25 for trained weights; 0.5 for random ones, whose scores spread widely: at 0.25 the
  /// decoding and NMS of their many boxes would take most of the frame.
  double score_threshold = 0.25;
};

/// The command line of the timing runs (everything but --profile and --write-weights).
struct Options
{
  std::vector<TrainedModel> models;
  std::string class_names;
  std::string image;
  int iterations = 10;
  bool onednn = false;
};

/// The value of the option at argv[i] (i advanced to it). @throws std::invalid_argument at the end.
std::string optionValue(int argc, char** argv, int& i)
{
  if (i + 1 >= argc)
  {
    throw std::invalid_argument(std::string(argv[i]) + " needs a value");
  }
  return argv[++i];
}

/// --input WxH or --weights W for the --model before it.
void parseModelOption(const std::string& arg, const std::string& text, std::vector<TrainedModel>& models)
{
  if (models.empty())
  {
    throw std::invalid_argument(arg + " applies to the --model before it: give --model first");
  }
  if (arg == "--weights")
  {
    models.back().weights = text;
    return;
  }
  char end = 0;
  if (std::sscanf(text.c_str(), "%dx%d%c", &models.back().width, &models.back().height, &end) != 2 ||
      models.back().width <= 0 || models.back().height <= 0)
  {
    throw std::invalid_argument("--input wants WxH, e.g. 640x192, got \"" + text + "\"");
  }
}

/// Parses this bench's options, removing them from argv (Google Benchmark's own flags are left).
/// Without --model: the default set with every variant. @throws std::invalid_argument.
Options parseOptions(int& argc, char** argv)
{
  Options options;
  std::vector<char*> rest{argv[0]};
  for (int i = 1; i < argc; ++i)
  {
    const std::string arg = argv[i];
    if (arg == "--model")
    {
      options.models.push_back({optionValue(argc, argv, i), "", 0, 0, "", 0, 0.25});
    }
    else if (arg == "--input" || arg == "--weights")
    {
      parseModelOption(arg, optionValue(argc, argv, i), options.models);
    }
    else if (arg == "--class-names" || arg == "--image")
    {
      (arg == "--image" ? options.image : options.class_names) = optionValue(argc, argv, i);
    }
    else if (arg == "--iterations")
    {
      options.iterations = std::atoi(optionValue(argc, argv, i).c_str());
      if (options.iterations <= 0)
      {
        throw std::invalid_argument("--iterations wants a positive count");
      }
    }
    else if (arg == "--onednn")
    {
      options.onednn = true;
    }
    else
    {
      rest.push_back(argv[i]);
    }
  }
  argc = static_cast<int>(rest.size());
  std::copy(rest.begin(), rest.end(), argv);
  if (options.models.empty())
  {
    if (!options.image.empty() || !options.class_names.empty())
    {
      throw std::invalid_argument("--image and --class-names apply to the models given by --model");
    }
    options.models = {{kCfgDir + "/yolov3-tiny.cfg", "", 416, 416, "yolov3-tiny-416", 10, 0.5},
                      {kCfgDir + "/yolov3.cfg", "", 416, 416, "yolov3-416", 3, 0.5},
                      {kCfgDir + "/yolov3.cfg", "", 608, 608, "yolov3-608", 2, 0.5}};
    options.onednn = true;
  }
  return options;
}

/// The variants to time: OpenCV's convolution, and oneDNN's where asked for and built.
std::vector<Conv> variants(const Options& options)
{
  std::vector<Conv> convs{Conv::kOpenCv};
  if (options.onednn && bench::onednnAvailable())
  {
    convs.push_back(Conv::kOnednn);
  }
  return convs;
}

/// The outputs of `model`'s network for `blob`, its 3 × 3 stride-1 convolutions by `conv`; of a
/// Darknet region layer its input (the box sizes before exp(): with random weights the residual
/// sums of yolov3 grow large enough that exp() overflows).
std::vector<cv::Mat> networkOutputs(const TrainedModel& model, const cv::Mat& blob, Conv conv)
{
  const ConvolutionScope scope(conv);
  cv::dnn::Net net = cv::dnn::readNet(model.model, model.weights);
  net.setPreferableBackend(cv::dnn::DNN_BACKEND_OPENCV);
  net.setPreferableTarget(cv::dnn::DNN_TARGET_CPU);
  std::vector<std::string> names = net.getUnconnectedOutLayersNames();
  for (std::string& name : names)
  {
    const int id = net.getLayerId(name);
    if (net.getLayer(id)->type == "Region")
    {
      name = net.getLayerInputs(id).at(0)->name;
    }
  }
  net.setInput(blob);
  std::vector<cv::Mat> outputs;
  net.forward(outputs, names);
  for (cv::Mat& output : outputs)
  {
    output = output.clone();
  }
  return outputs;
}

/// Compares the network outputs of every variant with OpenCV's convolution's on `blob` and prints
/// the largest difference. @throws std::runtime_error above 1e-3 of the largest output (or NaN).
void checkOutputs(const TrainedModel& model, const std::string& name, const cv::Mat& blob,
                  const std::vector<Conv>& convs)
{
  const std::vector<cv::Mat> reference = networkOutputs(model, blob, Conv::kOpenCv);
  for (const Conv conv : convs)
  {
    if (conv == Conv::kOpenCv)
    {
      continue;
    }
    const std::vector<cv::Mat> outputs = networkOutputs(model, blob, conv);
    double largest = 0.0;
    double difference = 0.0;
    for (std::size_t i = 0; i < reference.size() && i < outputs.size(); ++i)
    {
      largest = std::max(largest, cv::norm(reference[i], cv::NORM_INF));
      difference = std::max(difference, cv::norm(reference[i], outputs[i], cv::NORM_INF));
    }
    const double relative = largest > 0.0 ? difference / largest : difference;
    std::printf(
        "check %s%s: network outputs differ from OpenCV's convolution's by at most %.3g (%.2g of "
        "the largest, %.3g)\n",
        name.c_str(), suffix(conv).c_str(), difference, relative, largest);
    if (outputs.size() != reference.size() || !(relative <= 1e-3))  // NaN too
    {
      throw std::runtime_error(name + suffix(conv) +
                               ": the network outputs differ from OpenCV's convolution's");
    }
  }
}

/// Loads every model in every variant (a missing or mismatched model file is an error before
/// any run), checks the variants' outputs and registers one benchmark per model and variant,
/// named after the model (file and input size) and the variant.
void registerModels(const Options& options, const cv::Mat& image, const MachineInfo& peak)
{
  const std::vector<Conv> convs = variants(options);
  for (const TrainedModel& trained : options.models)
  {
    YoloDetectorConfig config;
    config.model_path = trained.model;
    config.weights_path = trained.weights;
    config.class_names_path = options.class_names.empty() ? kCfgDir + "/coco.names" : options.class_names;
    config.input_width = trained.width;
    config.input_height = trained.height;
    config.score_threshold = trained.score_threshold;
    std::string name = trained.name;
    for (const Conv conv : convs)
    {
      const std::shared_ptr<YoloDetector> detector = makeDetector(config, conv);
      if (name.empty())
      {
        name = std::filesystem::path(trained.model).filename().string() + "@" +
               std::to_string(detector->inputSize().width) + "x" +
               std::to_string(detector->inputSize().height);
      }
      if (conv == convs.front() && convs.size() > 1)
      {
        InputTransform transform;
        checkOutputs(trained, name, detector->makeInputBlob(image, PixelFormat::kBgr8, transform), convs);
      }
      benchmark::RegisterBenchmark((name + suffix(conv)).c_str(),
                                   [detector, image, peak](benchmark::State& state)
                                   { benchmarkDetector(state, *detector, image, peak); })
          ->Unit(benchmark::kMillisecond)
          ->Iterations(trained.iterations > 0 ? trained.iterations : options.iterations)
          ->MeasureProcessCPUTime()
          ->UseRealTime();
    }
  }
}

/// A temporary directory, deleted with everything in it at the end of its scope.
class TemporaryDirectory
{
public:
  TemporaryDirectory()
  {
    char pattern[] = "/tmp/gvf_bench_yolo_XXXXXX";
    if (mkdtemp(pattern) == nullptr)
    {
      throw std::runtime_error("cannot create a temporary directory");
    }
    path_ = pattern;
  }
  ~TemporaryDirectory() { std::filesystem::remove_all(path_); }
  TemporaryDirectory(const TemporaryDirectory&) = delete;
  TemporaryDirectory& operator=(const TemporaryDirectory&) = delete;
  const std::string& path() const { return path_; }

private:
  std::string path_;
};

/// Random weights (writeRandomWeights) for every Darknet cfg given without weights.
void fillRandomWeights(std::vector<TrainedModel>& models, const std::string& directory)
{
  std::map<std::string, std::string> written;
  for (TrainedModel& model : models)
  {
    if (model.weights.empty() && modelFormat(model.model) == ModelFormat::kDarknet)
    {
      std::string& weights = written[model.model];
      if (weights.empty())
      {
        weights = writeRandomWeights(model.model, directory);
      }
      model.weights = weights;
      model.score_threshold = 0.5;
    }
  }
}

/// --profile [MODEL] [--onednn].
int profileMain(int argc, char** argv)
{
  const std::string last = argv[argc - 1];
  const bool variant = last == "--onednn";
  const std::string name = argc - (variant ? 1 : 0) == 3 ? argv[2] : "yolov3-416";
  const std::map<std::string, Model> known{
      {"yolov3-tiny-416", {"yolov3-tiny-416", "yolov3-tiny.cfg", 416, 20}},
      {"yolov3-416", {"yolov3-416", "yolov3.cfg", 416, 5}},
      {"yolov3-608", {"yolov3-608", "yolov3.cfg", 608, 3}}};
  const auto model = known.find(name);
  if (argc > 4 || (argc == 4 && !variant) || model == known.end())
  {
    std::fprintf(stderr,
                 "bench_yolo: --profile [yolov3-tiny-416|yolov3-416|yolov3-608] [--onednn], "
                 "not %s\n",
                 name.c_str());
    return 2;
  }
  Model profiled = model->second;
  profiled.conv = variant ? Conv::kOnednn : Conv::kOpenCv;
  if (profiled.conv == Conv::kOnednn && !bench::onednnAvailable())
  {
    std::fprintf(stderr, "bench_yolo: %s\n", bench::onednnDescription().c_str());
    return 2;
  }
  const MachineInfo machine = machineInfo();
  cv::setNumThreads(machine.cores);
  std::printf("machine: %s\nopencv: %s, %d threads, 3x3 stride-1 convolutions: %s\n",
              machine.describe().c_str(), cv::getVersionString().c_str(), cv::getNumThreads(),
              profiled.conv == Conv::kOnednn ? bench::onednnDescription().c_str() : "OpenCV's");
  try
  {
    const TemporaryDirectory directory;
    return profileModel(profiled, writeRandomWeights(kCfgDir + "/" + profiled.cfg, directory.path()), machine,
                        profiled.iterations);
  }
  catch (const std::exception& e)
  {
    std::fprintf(stderr, "bench_yolo: %s\n", e.what());
    return 1;
  }
}

/// --write-weights DIR.
int writeWeightsMain(const std::string& directory)
{
  try
  {
    std::filesystem::create_directories(directory);
    for (const char* cfg : {"/yolov3-tiny.cfg", "/yolov3.cfg"})
    {
      std::printf("%s\n", writeRandomWeights(kCfgDir + cfg, directory).c_str());
    }
    return 0;
  }
  catch (const std::exception& e)
  {
    std::fprintf(stderr, "bench_yolo: %s\n", e.what());
    return 1;
  }
}

/// The machine, its peak, OpenCV and the convolution variants: printed and in the benchmark's
/// context.
void describeSetup(const MachineInfo& peak)
{
  std::ostringstream peak_text;
  peak_text << peak.cores << " cores x " << peak.mhz / 1000.0 << " GHz x " << peak.flopsPerCycle()
            << " FP32 FLOP/cycle = " << peak.peakGflops() << " GFLOP/s";
  const std::string opencv = cv::getVersionString() + ", " + std::to_string(cv::getNumThreads()) + " threads";
  benchmark::AddCustomContext("machine", peak.describe());
  benchmark::AddCustomContext("peak", peak_text.str());
  benchmark::AddCustomContext("opencv", opencv);
  benchmark::AddCustomContext("onednn", bench::onednnDescription());
  std::printf("machine: %s\nopencv: %s\nonednn: %s\n", peak.describe().c_str(), opencv.c_str(),
              bench::onednnDescription().c_str());
  std::fflush(stdout);
}

/// oneDNN's OpenMP threads spin after every primitive (libgomp's default), on the cores that the
/// OpenCV layers in between need (yolov3-tiny's forward pass 329 instead of 135 ms on 2 loaded
/// cores). libgomp reads its settings when it loads: the bench sets OMP_WAIT_POLICY=PASSIVE
/// unless it is set and runs itself again.
void passiveOpenMp(char** argv)
{
  if (bench::onednnAvailable() && std::getenv("OMP_WAIT_POLICY") == nullptr)
  {
    setenv("OMP_WAIT_POLICY", "PASSIVE", 1);
    execv("/proc/self/exe", argv);  // returns only where it failed: then the run goes on as it is
  }
}

}  // namespace

int main(int argc, char** argv)
{
  passiveOpenMp(argv);
  if (argc >= 2 && std::string(argv[1]) == "--profile")
  {
    return profileMain(argc, argv);
  }
  if (argc == 3 && std::string(argv[1]) == "--write-weights")
  {
    return writeWeightsMain(argv[2]);
  }
  const MachineInfo peak = machineInfo();
  cv::setNumThreads(peak.cores);
  describeSetup(peak);
  try
  {
    Options options = parseOptions(argc, argv);
    const TemporaryDirectory directory;
    fillRandomWeights(options.models, directory.path());
    registerModels(options, benchmarkImage(options.image), peak);
    if (options.onednn && bench::onednnAvailable())
    {
      std::printf("onednn implementations: %s\n", bench::onednnImplementations().c_str());
    }
    benchmark::Initialize(&argc, argv);
    if (benchmark::ReportUnrecognizedArguments(argc, argv))
    {
      return 2;
    }
    benchmark::RunSpecifiedBenchmarks();
    benchmark::Shutdown();
    return 0;
  }
  catch (const std::invalid_argument& e)
  {
    std::fprintf(stderr, "bench_yolo: %s\n", e.what());
    return 2;
  }
  catch (const std::exception& e)
  {
    std::fprintf(stderr, "bench_yolo: %s\n", e.what());
    return 1;
  }
}
