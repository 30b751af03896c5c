// Inference time of the real YOLOv3 (416, 608) and YOLOv3-tiny (416) architectures through
// YoloDetector (preprocessing, OpenCV DNN forward pass, decoding, NMS) on a KITTI-sized image,
// with random weights written in the Darknet format to a temporary directory (speed does not
// depend on training). Reports ms per frame, achieved GFLOP/s (cv::dnn::Net::getFLOPS / time)
// and the machine's peak.
//
// Every model runs twice: with the detector's default, the 3 × 3 stride-1 convolutions by the
// Winograd layer (detection/winograd_convolution.h), and with OpenCV's own convolution for every
// layer (names ending in "/opencv_conv"). The FLOP bound is the direct convolution's in both.
//
// Run: devel/lib/grid_vision_fusion/bench_yolo [--benchmark_filter=tiny]
//      devel/lib/grid_vision_fusion/bench_yolo --write-weights DIR   (writes yolov3-tiny.weights
//      and yolov3.weights with these random values into DIR and exits: for run_pipeline
//      --benchmark with a real network architecture)
//      devel/lib/grid_vision_fusion/bench_yolo --profile [yolov3-416|yolov3-tiny-416|yolov3-608]
//      [--opencv-conv]
//      (per layer type: time from cv::dnn::Net::getPerfProfile, FLOPs, achieved GFLOP/s and the
//      share of the frame; convolutions also by kernel size: where the time beyond the FLOP
//      bound goes)
//      devel/lib/grid_vision_fusion/bench_yolo --model M.onnx --input 640x192 [--model M2 --input WxH
//      ...] [--weights W] [--class-names N] [--image FILE] [--iterations N] [--opencv-conv]
//      [--benchmark_repetitions=5 --benchmark_enable_random_interleaving=true]
//      (trained models, e.g. those of scripts/fetch_model.sh, instead of the random Darknet ones:
//      each --model with the --input (and --weights for a Darknet cfg) that follow it; several
//      in one run for figures taken under the same load; on --image, a KITTI frame, or on a
//      random image of KITTI's size)
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
#include <random>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "grid_vision_fusion/cli/machine_info.h"
#include "grid_vision_fusion/detection/winograd_convolution.h"
#include "grid_vision_fusion/detection/yolo_detector.h"

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

struct Model
{
  std::string name;
  std::string cfg;
  int input = 0;
  int iterations = 0;
  bool winograd = true;  ///< false: OpenCV's convolution for every layer
};

/// The detector configuration of a model of models/yolo with the given weights.
YoloDetectorConfig darknetConfig(const Model& model, const std::string& weights)
{
  YoloDetectorConfig config;
  config.model_path = kCfgDir + "/" + model.cfg;
  config.weights_path = weights;
  config.class_names_path = kCfgDir + "/coco.names";
  config.input_width = model.input;
  config.input_height = model.input;
  config.score_threshold = 0.5;
  config.winograd = model.winograd;
  return config;
}

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

void benchmarkModel(benchmark::State& state, const YoloDetectorConfig& config, const cv::Mat& image,
                    const MachineInfo& peak)
{
  YoloDetector detector(config);
  benchmarkDetector(state, detector, image, peak);
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
    const WinogradConvolutionScope winograd(model.winograd);  // until the layers exist
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
    if (layer->type == kWinogradLayerType)
    {
      LayerGroup& group = by_kernel["3x3 (Winograd)"];
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

/// A trained model given on the command line.
struct TrainedModel
{
  std::string model;
  std::string weights;
  int width = 0;
  int height = 0;
};

/// The --model ... options (removed from argv, Google Benchmark's own flags left); false when
/// there is none. @throws std::invalid_argument for a malformed option.
bool parseTrainedModels(int& argc, char** argv, std::vector<TrainedModel>& models, std::string& class_names,
                        std::string& image, int& iterations, bool& opencv_conv)
{
  std::vector<char*> rest{argv[0]};
  for (int i = 1; i < argc; ++i)
  {
    const std::string arg = argv[i];
    const auto value = [&]() -> std::string
    {
      if (i + 1 >= argc)
      {
        throw std::invalid_argument(arg + " needs a value");
      }
      return argv[++i];
    };
    if (arg == "--model")
    {
      models.push_back({value(), "", 0, 0});
    }
    else if (arg == "--input" || arg == "--weights")
    {
      if (models.empty())
      {
        throw std::invalid_argument(arg + " applies to the --model before it: give --model first");
      }
      const std::string text = value();
      if (arg == "--weights")
      {
        models.back().weights = text;
        continue;
      }
      char end = 0;
      if (std::sscanf(text.c_str(), "%dx%d%c", &models.back().width, &models.back().height, &end) != 2 ||
          models.back().width <= 0 || models.back().height <= 0)
      {
        throw std::invalid_argument("--input wants WxH, e.g. 640x192, got \"" + text + "\"");
      }
    }
    else if (arg == "--class-names")
    {
      class_names = value();
    }
    else if (arg == "--image")
    {
      image = value();
    }
    else if (arg == "--iterations")
    {
      iterations = std::atoi(value().c_str());
      if (iterations <= 0)
      {
        throw std::invalid_argument("--iterations wants a positive count");
      }
    }
    else if (arg == "--opencv-conv")
    {
      opencv_conv = true;
    }
    else
    {
      rest.push_back(argv[i]);
    }
  }
  if (models.empty())
  {
    if (!image.empty() || !class_names.empty())
    {
      throw std::invalid_argument("--image and --class-names apply to the models given by --model");
    }
    return false;
  }
  argc = static_cast<int>(rest.size());
  std::copy(rest.begin(), rest.end(), argv);
  return true;
}

/// Registers one benchmark per trained model (and its /opencv_conv variant when asked), named
/// after the model file and its input size.
void registerTrainedModels(const std::vector<TrainedModel>& models, const std::string& class_names,
                           const cv::Mat& image, int iterations, bool opencv_conv, const MachineInfo& peak)
{
  for (const TrainedModel& trained : models)
  {
    for (const bool winograd : {true, false})
    {
      if (!winograd && !opencv_conv)
      {
        continue;
      }
      YoloDetectorConfig config;
      config.model_path = trained.model;
      config.weights_path = trained.weights;
      config.class_names_path = class_names.empty() ? kCfgDir + "/coco.names" : class_names;
      config.input_width = trained.width;
      config.input_height = trained.height;
      config.score_threshold = 0.25;
      config.winograd = winograd;
      // Loaded here, so that a missing or mismatched model file is an error before any run.
      const auto detector = std::make_shared<YoloDetector>(config);
      const std::string size =
          trained.width > 0 ? std::to_string(trained.width) + "x" + std::to_string(trained.height) : "cfg";
      const std::string name = std::filesystem::path(trained.model).filename().string() + "@" + size +
                               (winograd ? "" : "/opencv_conv");
      benchmark::RegisterBenchmark(name.c_str(), [detector, image, peak](benchmark::State& state)
                                   { benchmarkDetector(state, *detector, image, peak); })
          ->Unit(benchmark::kMillisecond)
          ->Iterations(iterations)
          ->MeasureProcessCPUTime()
          ->UseRealTime();
    }
  }
}

}  // namespace

int main(int argc, char** argv)
{
  if (argc >= 2 && argc <= 4 && std::string(argv[1]) == "--profile")
  {
    const bool opencv_conv = std::string(argv[argc - 1]) == "--opencv-conv";
    if (argc == 4 && !opencv_conv)
    {
      std::fprintf(stderr, "bench_yolo: --profile [MODEL] [--opencv-conv], not %s\n", argv[3]);
      return 2;
    }
    const std::string name = argc - (opencv_conv ? 1 : 0) == 3 ? argv[2] : "yolov3-416";
    const std::map<std::string, Model> known{
        {"yolov3-tiny-416", {"yolov3-tiny-416", "yolov3-tiny.cfg", 416, 20}},
        {"yolov3-416", {"yolov3-416", "yolov3.cfg", 416, 5}},
        {"yolov3-608", {"yolov3-608", "yolov3.cfg", 608, 3}}};
    const auto model = known.find(name);
    if (model == known.end())
    {
      std::fprintf(stderr, "bench_yolo: --profile takes yolov3-tiny-416, yolov3-416 or yolov3-608, not %s\n",
                   name.c_str());
      return 2;
    }
    Model profiled = model->second;
    profiled.winograd = !opencv_conv;
    const MachineInfo machine = machineInfo();
    cv::setNumThreads(machine.cores);
    std::printf("machine: %s\nopencv: %s, %d threads, 3x3 stride-1 convolutions: %s\n",
                machine.describe().c_str(), cv::getVersionString().c_str(), cv::getNumThreads(),
                profiled.winograd && winogradSupported() ? "Winograd F(2x2, 3x3)" : "OpenCV's");
    char pattern[] = "/tmp/gvf_bench_yolo_XXXXXX";
    if (mkdtemp(pattern) == nullptr)
    {
      std::fprintf(stderr, "bench_yolo: cannot create a temporary directory\n");
      return 1;
    }
    int status = 1;
    try
    {
      status = profileModel(profiled, writeRandomWeights(kCfgDir + "/" + profiled.cfg, pattern), machine,
                            profiled.iterations);
    }
    catch (const std::exception& e)
    {
      std::fprintf(stderr, "bench_yolo: %s\n", e.what());
    }
    std::filesystem::remove_all(pattern);
    return status;
  }
  if (argc == 3 && std::string(argv[1]) == "--write-weights")
  {
    try
    {
      std::filesystem::create_directories(argv[2]);
      for (const char* cfg : {"/yolov3-tiny.cfg", "/yolov3.cfg"})
      {
        std::printf("%s\n", writeRandomWeights(kCfgDir + cfg, argv[2]).c_str());
      }
      return 0;
    }
    catch (const std::exception& e)
    {
      std::fprintf(stderr, "bench_yolo: %s\n", e.what());
      return 1;
    }
  }
  const MachineInfo peak = machineInfo();
  cv::setNumThreads(peak.cores);
  std::ostringstream peak_text;
  peak_text << peak.cores << " cores x " << peak.mhz / 1000.0 << " GHz x " << peak.flopsPerCycle()
            << " FP32 FLOP/cycle = " << peak.peakGflops() << " GFLOP/s";
  benchmark::AddCustomContext("machine", peak.describe());
  benchmark::AddCustomContext("peak", peak_text.str());
  benchmark::AddCustomContext(
      "opencv", cv::getVersionString() + ", " + std::to_string(cv::getNumThreads()) + " threads");
  benchmark::AddCustomContext("winograd",
                              winogradSupported()
                                  ? "3x3 stride-1 convolutions by Winograd F(2x2, 3x3) unless /opencv_conv"
                                  : "not supported on this CPU (no AVX2/FMA): OpenCV's convolution in both");

  std::printf("machine: %s\nopencv: %s, %d threads\n", peak.describe().c_str(),
              cv::getVersionString().c_str(), cv::getNumThreads());
  std::fflush(stdout);

  std::vector<TrainedModel> trained;
  std::string class_names, image_path;
  int iterations = 10;
  bool opencv_conv = false;
  try
  {
    if (parseTrainedModels(argc, argv, trained, class_names, image_path, iterations, opencv_conv))
    {
      registerTrainedModels(trained, class_names, benchmarkImage(image_path), iterations, opencv_conv, peak);
      benchmark::Initialize(&argc, argv);
      if (benchmark::ReportUnrecognizedArguments(argc, argv))
      {
        return 2;
      }
      benchmark::RunSpecifiedBenchmarks();
      benchmark::Shutdown();
      return 0;
    }
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

  char pattern[] = "/tmp/gvf_bench_yolo_XXXXXX";
  if (mkdtemp(pattern) == nullptr)
  {
    std::fprintf(stderr, "cannot create a temporary directory\n");
    return 1;
  }
  const std::string directory = pattern;
  const std::vector<Model> models{{"yolov3-tiny-416", "yolov3-tiny.cfg", 416, 10, true},
                                  {"yolov3-tiny-416/opencv_conv", "yolov3-tiny.cfg", 416, 10, false},
                                  {"yolov3-416", "yolov3.cfg", 416, 3, true},
                                  {"yolov3-416/opencv_conv", "yolov3.cfg", 416, 3, false},
                                  {"yolov3-608", "yolov3.cfg", 608, 2, true},
                                  {"yolov3-608/opencv_conv", "yolov3.cfg", 608, 2, false}};
  int status = 0;
  try
  {
    const std::string tiny_weights = writeRandomWeights(kCfgDir + "/yolov3-tiny.cfg", directory);
    const std::string yolov3_weights = writeRandomWeights(kCfgDir + "/yolov3.cfg", directory);
    for (const Model& model : models)
    {
      const std::string weights = model.cfg == "yolov3.cfg" ? yolov3_weights : tiny_weights;
      const YoloDetectorConfig config = darknetConfig(model, weights);
      const cv::Mat image = benchmarkImage("");
      benchmark::RegisterBenchmark(model.name.c_str(), [config, image, peak](benchmark::State& state)
                                   { benchmarkModel(state, config, image, peak); })
          ->Unit(benchmark::kMillisecond)
          ->Iterations(model.iterations)
          ->MeasureProcessCPUTime()
          ->UseRealTime();
    }
    benchmark::Initialize(&argc, argv);
    benchmark::RunSpecifiedBenchmarks();
    benchmark::Shutdown();
  }
  catch (const std::exception& e)
  {
    std::fprintf(stderr, "bench_yolo: %s\n", e.what());
    status = 1;
  }
  std::filesystem::remove_all(directory);
  return status;
}
