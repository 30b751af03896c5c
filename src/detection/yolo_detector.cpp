#include "grid_vision_fusion/detection/yolo_detector.h"

#include "grid_vision_fusion/detection/winograd_convolution.h"

#include <opencv2/dnn.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <fstream>
#include <sstream>

namespace grid_vision_fusion
{
namespace
{
constexpr int kMaxInputSize = 4096;

bool endsWith(const std::string& text, const std::string& suffix)
{
  return text.size() >= suffix.size() &&
         text.compare(text.size() - suffix.size(), suffix.size(), suffix) == 0;
}

std::string trim(const std::string& text)
{
  const auto first = text.find_first_not_of(" \t\r\n");
  if (first == std::string::npos)
  {
    return "";
  }
  const auto last = text.find_last_not_of(" \t\r\n");
  return text.substr(first, last - first + 1);
}

int backendId(const std::string& name)
{
  if (name == "opencv")
  {
    return cv::dnn::DNN_BACKEND_OPENCV;
  }
  if (name == "cuda")
  {
    return cv::dnn::DNN_BACKEND_CUDA;
  }
  if (name == "inference_engine")
  {
    return cv::dnn::DNN_BACKEND_INFERENCE_ENGINE;
  }
  return -1;
}

int targetId(const std::string& name)
{
  if (name == "cpu")
  {
    return cv::dnn::DNN_TARGET_CPU;
  }
  if (name == "opencl")
  {
    return cv::dnn::DNN_TARGET_OPENCL;
  }
  if (name == "opencl_fp16")
  {
    return cv::dnn::DNN_TARGET_OPENCL_FP16;
  }
  if (name == "cuda")
  {
    return cv::dnn::DNN_TARGET_CUDA;
  }
  if (name == "cuda_fp16")
  {
    return cv::dnn::DNN_TARGET_CUDA_FP16;
  }
  return -1;
}

/// One section of a Darknet cfg: its name, the line it starts on and its key=value pairs.
struct CfgSection
{
  std::string name;
  std::size_t line = 0;
  std::map<std::string, std::string> values;
};

std::vector<CfgSection> readCfgSections(std::istream& file, const std::string& path)
{
  std::vector<CfgSection> sections;
  std::string text;
  std::size_t line = 0;
  while (std::getline(file, text))
  {
    ++line;
    const std::string content = trim(text.substr(0, text.find_first_of("#;")));
    if (content.empty())
    {
      continue;
    }
    if (content.front() == '[')
    {
      if (content.back() != ']')
      {
        throw YoloModelError(path + ":" + std::to_string(line) + ": malformed section header '" + content +
                             "'");
      }
      sections.push_back({content.substr(1, content.size() - 2), line, {}});
      continue;
    }
    const auto equals = content.find('=');
    if (equals == std::string::npos || sections.empty())
    {
      throw YoloModelError(path + ":" + std::to_string(line) + ": expected [section] or key=value, got '" +
                           content + "'");
    }
    sections.back().values[trim(content.substr(0, equals))] = trim(content.substr(equals + 1));
  }
  if (file.bad())
  {
    throw YoloModelError(path + ": read error");
  }
  return sections;
}

int cfgInt(const CfgSection& section, const std::string& key, int fallback, const std::string& path)
{
  const auto it = section.values.find(key);
  if (it == section.values.end())
  {
    return fallback;
  }
  try
  {
    std::size_t used = 0;
    const int value = std::stoi(it->second, &used);
    if (used == it->second.size())
    {
      return value;
    }
  }
  catch (const std::exception&)
  {
  }
  throw YoloModelError(path + ":" + std::to_string(section.line) + ": [" + section.name + "] " + key +
                       " is not an integer: '" + it->second + "'");
}

std::vector<int> cfgIntList(const CfgSection& section, const std::string& key, const std::string& path)
{
  std::vector<int> values;
  const auto it = section.values.find(key);
  if (it == section.values.end())
  {
    return values;
  }
  std::stringstream list(it->second);
  for (std::string item; std::getline(list, item, ',');)
  {
    CfgSection one{section.name, section.line, {{key, trim(item)}}};
    values.push_back(cfgInt(one, key, 0, path));
  }
  return values;
}

/// Output shape of a Darknet layer, in 64 bits so that no layer arithmetic overflows: every
/// dimension is at most kMaxLayerDimension, every cfg value an int.
struct LayerShape
{
  std::int64_t channels = 0;
  std::int64_t height = 0;
  std::int64_t width = 0;
};

/// Largest channel count, height or width of a layer output; far above any real network.
constexpr std::int64_t kMaxLayerDimension = std::int64_t{1} << 20;
/// Largest parameter count of a cfg (a 256 GiB weights file); far above any real network.
constexpr std::size_t kMaxParameters = std::size_t{1} << 36;

/// a · b for parameter counts. @throws YoloModelError (naming `where`) beyond kMaxParameters.
std::size_t parameterProduct(std::size_t a, std::size_t b, const std::string& where)
{
  if (b != 0 && a > kMaxParameters / b)
  {
    throw YoloModelError(where + "needs more than " + std::to_string(kMaxParameters) + " parameters");
  }
  return a * b;
}

/// A layer section of a cfg: where it is (for the messages) and the layers before it.
struct LayerContext
{
  const CfgSection& section;
  const std::string& cfg_path;
  const std::vector<LayerShape>& shapes;  ///< output shapes of the layers before it
  std::string where;                      ///< "<cfg>:<line>: [<name>] "

  LayerContext(const CfgSection& s, const std::string& path, const std::vector<LayerShape>& before)
      : section(s),
        cfg_path(path),
        shapes(before),
        where(path + ":" + std::to_string(s.line) + ": [" + s.name + "] ")
  {
  }

  int integer(const std::string& key, int fallback) const { return cfgInt(section, key, fallback, cfg_path); }

  /// The layer `reference` names (an index, or relative to this layer when negative).
  /// @throws YoloModelError when there is no such layer before this one.
  const LayerShape& layerAt(int reference) const
  {
    const int index = static_cast<int>(shapes.size());
    const int absolute = reference < 0 ? index + reference : reference;
    if (absolute < 0 || absolute >= index)
    {
      throw YoloModelError(where + "refers to layer " + std::to_string(reference) + ", which does not exist");
    }
    return shapes[static_cast<std::size_t>(absolute)];
  }
};

/// The input of the network, from its [net] section. @throws YoloModelError when not positive or too large.
LayerShape netInput(const CfgSection& net, const std::string& cfg_path, DarknetCfgInfo& info)
{
  info.input_width = cfgInt(net, "width", 0, cfg_path);
  info.input_height = cfgInt(net, "height", 0, cfg_path);
  info.input_channels = cfgInt(net, "channels", 3, cfg_path);
  if (info.input_width <= 0 || info.input_height <= 0 || info.input_channels <= 0)
  {
    throw YoloModelError(cfg_path + ":" + std::to_string(net.line) +
                         ": [net] needs positive width, height and channels");
  }
  if (info.input_width > kMaxLayerDimension || info.input_height > kMaxLayerDimension ||
      info.input_channels > kMaxLayerDimension)
  {
    throw YoloModelError(cfg_path + ":" + std::to_string(net.line) +
                         ": [net] width, height and channels must be at most " +
                         std::to_string(kMaxLayerDimension));
  }
  return {info.input_channels, info.input_height, info.input_width};
}

/// [convolutional]: its output shape; its weights block and parameters added to `info`.
LayerShape convolutionalLayer(const LayerContext& layer, const LayerShape& previous, DarknetCfgInfo& info)
{
  const std::string& where = layer.where;
  const int filters = layer.integer("filters", 1);
  const int size = layer.integer("size", 1);
  const int stride = layer.integer("stride", 1);
  const int groups = layer.integer("groups", 1);
  const bool batch_normalize = layer.integer("batch_normalize", 0) != 0;
  int padding = layer.integer("padding", 0);
  if (layer.integer("pad", 0) != 0)
  {
    padding = size / 2;
  }
  if (filters <= 0 || size <= 0 || stride <= 0 || groups <= 0 || previous.channels % groups != 0)
  {
    throw YoloModelError(where + "needs positive filters, size, stride and groups dividing the " +
                         std::to_string(previous.channels) + " input channels");
  }
  const std::size_t weights = parameterProduct(
      parameterProduct(static_cast<std::size_t>(filters),
                       static_cast<std::size_t>(previous.channels / groups), where),
      parameterProduct(static_cast<std::size_t>(size), static_cast<std::size_t>(size), where), where);
  info.blocks.push_back({filters, weights, batch_normalize});
  info.parameters += static_cast<std::size_t>(filters) * (batch_normalize ? 4 : 1) + weights;
  return {filters, (previous.height + 2 * std::int64_t{padding} - size) / stride + 1,
          (previous.width + 2 * std::int64_t{padding} - size) / stride + 1};
}

/// [connected]: its output shape; its weights block and parameters added to `info`.
LayerShape connectedLayer(const LayerContext& layer, const LayerShape& previous, DarknetCfgInfo& info)
{
  const std::string& where = layer.where;
  const int outputs = layer.integer("output", 1);
  const bool batch_normalize = layer.integer("batch_normalize", 0) != 0;
  const std::size_t inputs =
      parameterProduct(parameterProduct(static_cast<std::size_t>(previous.channels),
                                        static_cast<std::size_t>(previous.height), where),
                       static_cast<std::size_t>(previous.width), where);
  if (outputs <= 0)
  {
    throw YoloModelError(where + "output must be positive");
  }
  const std::size_t weights = parameterProduct(static_cast<std::size_t>(outputs), inputs, where);
  info.blocks.push_back({outputs, weights, batch_normalize});
  info.parameters += weights + static_cast<std::size_t>(outputs) * (batch_normalize ? 4 : 1);
  return {outputs, 1, 1};
}

/// [maxpool]: its output shape.
LayerShape maxpoolLayer(const LayerContext& layer, const LayerShape& previous)
{
  const int stride = layer.integer("stride", 1);
  const int size = layer.integer("size", stride);
  const int padding = layer.integer("padding", size - 1);
  if (stride <= 0 || size <= 0)
  {
    throw YoloModelError(layer.where + "needs positive size and stride");
  }
  return {previous.channels, (previous.height + std::int64_t{padding} - size) / stride + 1,
          (previous.width + std::int64_t{padding} - size) / stride + 1};
}

/// [upsample] (a negative stride divides): its output shape.
LayerShape upsampleLayer(const LayerContext& layer, const LayerShape& previous)
{
  const int stride = layer.integer("stride", 2);
  if (stride == 0)
  {
    throw YoloModelError(layer.where + "stride must not be 0");
  }
  return stride > 0 ? LayerShape{previous.channels, previous.height * stride, previous.width * stride}
                    : LayerShape{previous.channels, previous.height / -std::int64_t{stride},
                                 previous.width / -std::int64_t{stride}};
}

/// [reorg]: its output shape.
LayerShape reorgLayer(const LayerContext& layer, const LayerShape& previous)
{
  const int stride = layer.integer("stride", 1);
  if (stride <= 0 || stride > previous.height || stride > previous.width)
  {
    throw YoloModelError(layer.where + "stride must be positive and at most the input's height and width");
  }
  return {previous.channels * stride * stride, previous.height / stride, previous.width / stride};
}

/// [route]: the layers it concatenates, their channels split in `groups`.
LayerShape routeLayer(const LayerContext& layer)
{
  const std::vector<int> layers = cfgIntList(layer.section, "layers", layer.cfg_path);
  const int groups = layer.integer("groups", 1);
  if (layers.empty() || groups <= 0)
  {
    throw YoloModelError(layer.where + "needs layers= and positive groups");
  }
  LayerShape out = layer.layerAt(layers.front());
  out.channels = 0;
  for (int reference : layers)
  {
    out.channels += layer.layerAt(reference).channels;
  }
  out.channels /= groups;
  return out;
}

/// [yolo] or [region]: one more detection layer in `info`, all of the same class count.
void yoloLayer(const LayerContext& layer, DarknetCfgInfo& info)
{
  const int classes = layer.integer("classes", 20);
  if (classes <= 0)
  {
    throw YoloModelError(layer.where + "classes must be positive");
  }
  if (info.num_classes >= 0 && info.num_classes != classes)
  {
    throw YoloModelError(layer.where + "has classes=" + std::to_string(classes) +
                         " but an earlier layer has " + std::to_string(info.num_classes));
  }
  info.num_classes = classes;
  ++info.yolo_layers;
}

/// The output shape of a layer whose input is `previous`; its parameters added to `info`.
/// @throws YoloModelError for an unsupported layer type or a bad value.
LayerShape layerOutput(const LayerContext& layer, const LayerShape& previous, DarknetCfgInfo& info)
{
  const std::string& name = layer.section.name;
  if (name == "convolutional")
  {
    return convolutionalLayer(layer, previous, info);
  }
  if (name == "connected")
  {
    return connectedLayer(layer, previous, info);
  }
  if (name == "maxpool")
  {
    return maxpoolLayer(layer, previous);
  }
  if (name == "avgpool")
  {
    return {previous.channels, 1, 1};
  }
  if (name == "upsample")
  {
    return upsampleLayer(layer, previous);
  }
  if (name == "reorg")
  {
    return reorgLayer(layer, previous);
  }
  if (name == "route")
  {
    return routeLayer(layer);
  }
  if (name == "shortcut" || name == "scale_channels" || name == "sam")
  {
    for (int reference : cfgIntList(layer.section, "from", layer.cfg_path))
    {
      layer.layerAt(reference);
    }
  }
  else if (name == "yolo" || name == "region")
  {
    yoloLayer(layer, info);
  }
  else if (name != "dropout" && name != "softmax")
  {
    throw YoloModelError(layer.where + "unsupported layer type");
  }
  return previous;
}

/// @throws YoloModelError (naming `where`) when a layer's output shape is too large or empty.
void checkLayerShape(const LayerShape& out, const std::string& where)
{
  if (out.channels > kMaxLayerDimension || out.height > kMaxLayerDimension || out.width > kMaxLayerDimension)
  {
    throw YoloModelError(where + "output shape " + std::to_string(out.channels) + "x" +
                         std::to_string(out.height) + "x" + std::to_string(out.width) +
                         " is too large (limit " + std::to_string(kMaxLayerDimension) + " per dimension)");
  }
  if (out.channels <= 0 || out.height <= 0 || out.width <= 0)
  {
    throw YoloModelError(where + "output shape " + std::to_string(out.channels) + "x" +
                         std::to_string(out.height) + "x" + std::to_string(out.width) + " is empty");
  }
}

}  // namespace

YoloOutputLayout yoloOutputLayoutFromString(const std::string& name)
{
  if (name == "pixels")
  {
    return YoloOutputLayout::kPixels;
  }
  if (name == "opencv_region")
  {
    return YoloOutputLayout::kOpenCvRegion;
  }
  throw std::invalid_argument("onnx_layout must be \"pixels\" or \"opencv_region\", got \"" + name + "\"");
}

std::string toString(YoloOutputLayout layout)
{
  return layout == YoloOutputLayout::kPixels ? "pixels" : "opencv_region";
}

ResizeMode resizeModeFromString(const std::string& name)
{
  if (name == "letterbox")
  {
    return ResizeMode::kLetterbox;
  }
  if (name == "resize")
  {
    return ResizeMode::kStretch;
  }
  throw std::invalid_argument("resize mode must be \"letterbox\" or \"resize\", got \"" + name + "\"");
}

std::string toString(ResizeMode mode)
{
  return mode == ResizeMode::kLetterbox ? "letterbox" : "resize";
}

ModelFormat modelFormat(const std::string& model_path)
{
  if (endsWith(model_path, ".cfg"))
  {
    return ModelFormat::kDarknet;
  }
  return endsWith(model_path, ".onnx") ? ModelFormat::kOnnx : ModelFormat::kUnknown;
}

void YoloDetectorConfig::validate() const
{
  const bool darknet = modelFormat(model_path) == ModelFormat::kDarknet;
  const bool onnx = modelFormat(model_path) == ModelFormat::kOnnx;
  if (!darknet && !onnx)
  {
    throw std::invalid_argument("model must name a Darknet .cfg or an .onnx file, got \"" + model_path +
                                "\"");
  }
  if (darknet && weights_path.empty())
  {
    throw std::invalid_argument("weights must name the .weights file of the Darknet model " + model_path);
  }
  if (onnx && !weights_path.empty())
  {
    throw std::invalid_argument("weights must be empty for an ONNX model, got \"" + weights_path + "\"");
  }
  if (class_names_path.empty())
  {
    throw std::invalid_argument("class_names must name the class names file");
  }
  if (input_width < 0 || input_width > kMaxInputSize || input_height < 0 || input_height > kMaxInputSize)
  {
    throw std::invalid_argument("input_width and input_height must be in [0, 4096], got " +
                                std::to_string(input_width) + " x " + std::to_string(input_height));
  }
  if ((input_width == 0) != (input_height == 0))
  {
    throw std::invalid_argument(
        "input_width and input_height must both be 0 (the model's own size) or both set");
  }
  if (!(score_threshold >= 0.0 && score_threshold <= 1.0))
  {
    throw std::invalid_argument("score_threshold must be in [0, 1], got " + std::to_string(score_threshold));
  }
  if (!(nms_threshold >= 0.0 && nms_threshold <= 1.0))
  {
    throw std::invalid_argument("nms_threshold must be in [0, 1], got " + std::to_string(nms_threshold));
  }
  if (backendId(backend) < 0)
  {
    throw std::invalid_argument("backend must be \"opencv\", \"cuda\" or \"inference_engine\", got \"" +
                                backend + "\"");
  }
  if (targetId(target) < 0)
  {
    throw std::invalid_argument(
        "target must be \"cpu\", \"opencl\", \"opencl_fp16\", \"cuda\" or \"cuda_fp16\", got \"" + target +
        "\"");
  }
  for (const auto& entry : class_map)
  {
    if (entry.first.empty() || entry.second.empty())
    {
      throw std::invalid_argument("class_map entries must have non-empty names, got \"" + entry.first +
                                  "\" -> \"" + entry.second + "\"");
    }
  }
  for (const auto& entry : rider_merge)
  {
    if (entry.first.empty() || entry.second.empty() || entry.first == rider_class)
    {
      throw std::invalid_argument("rider_merge entries must map a vehicle class other than rider_class \"" +
                                  rider_class + "\" to a non-empty label, got \"" + entry.first + "\" -> \"" +
                                  entry.second + "\"");
    }
  }
  if (!rider_merge.empty() && rider_class.empty())
  {
    throw std::invalid_argument(
        "rider_class must name the riders' model class (e.g. person) for rider_merge");
  }
}

DarknetCfgInfo parseDarknetCfg(const std::string& cfg_path)
{
  std::ifstream file(cfg_path);
  if (!file)
  {
    throw YoloModelError(cfg_path + ": cannot open the Darknet cfg file");
  }
  return parseDarknetCfg(file, cfg_path);
}

DarknetCfgInfo parseDarknetCfg(std::istream& input, const std::string& cfg_path)
{
  const std::vector<CfgSection> sections = readCfgSections(input, cfg_path);
  if (sections.empty() || (sections.front().name != "net" && sections.front().name != "network"))
  {
    throw YoloModelError(cfg_path + ": not a Darknet cfg (the first section must be [net])");
  }
  DarknetCfgInfo info;
  LayerShape previous = netInput(sections.front(), cfg_path, info);
  std::vector<LayerShape> shapes;
  for (std::size_t i = 1; i < sections.size(); ++i)
  {
    const LayerContext layer(sections[i], cfg_path, shapes);
    const LayerShape out = layerOutput(layer, previous, info);
    checkLayerShape(out, layer.where);
    shapes.push_back(out);
    previous = out;
  }
  return info;
}

std::size_t checkDarknetWeights(const std::string& weights_path, const std::string& cfg_path,
                                const DarknetCfgInfo& info)
{
  std::ifstream file(weights_path, std::ios::binary);
  if (!file)
  {
    throw YoloModelError(weights_path + ": cannot open the Darknet weights file");
  }
  return checkDarknetWeights(file, weights_path, cfg_path, info);
}

std::size_t checkDarknetWeights(std::istream& file, const std::string& weights_path,
                                const std::string& cfg_path, const DarknetCfgInfo& info)
{
  file.seekg(0, std::ios::end);
  const std::streamoff file_size = file.tellg();
  file.seekg(0);
  std::int32_t version[3] = {0, 0, 0};
  if (file_size < static_cast<std::streamoff>(sizeof(version)) ||
      !file.read(reinterpret_cast<char*>(version), sizeof(version)))
  {
    throw YoloModelError(weights_path + ": truncated Darknet weights file: " + std::to_string(file_size) +
                         " bytes, shorter than its header");
  }
  // As Darknet and OpenCV's importer: `seen` is 64 bits from version 0.2 on, 32 bits before.
  // In 64 bits: a header of any version, however large, must not overflow.
  const std::int64_t major_minor = static_cast<std::int64_t>(version[0]) * 10 + version[1];
  const std::size_t header =
      3 * sizeof(std::int32_t) + (major_minor >= 2 ? sizeof(std::int64_t) : sizeof(std::int32_t));
  const std::size_t expected = header + sizeof(float) * info.parameters;
  const auto actual = static_cast<std::size_t>(file_size);
  if (actual != expected)
  {
    throw YoloModelError(weights_path + ": " + (actual < expected ? "truncated" : "too long for its cfg") +
                         " Darknet weights file: " + std::to_string(actual) + " bytes, but " + cfg_path +
                         " needs " + std::to_string(expected) + " (" + std::to_string(header) +
                         "-byte header + " + std::to_string(info.parameters) + " float32 parameters)");
  }
  return expected;
}

std::vector<std::string> readClassNames(const std::string& path)
{
  std::ifstream file(path);
  if (!file)
  {
    throw YoloModelError(path + ": cannot open the class names file");
  }
  return parseClassNames(file, path);
}

std::vector<std::string> parseClassNames(std::istream& input, const std::string& path)
{
  std::vector<std::string> names;
  for (std::string line; std::getline(input, line);)
  {
    const std::string name = trim(line);
    if (!name.empty())
    {
      names.push_back(name);
    }
  }
  if (names.empty())
  {
    throw YoloModelError(path + ": the class names file lists no class");
  }
  return names;
}

InputTransform InputTransform::make(cv::Size image_size, cv::Size input_size, ResizeMode mode)
{
  if (image_size.width <= 0 || image_size.height <= 0 || input_size.width <= 0 || input_size.height <= 0)
  {
    throw std::invalid_argument("InputTransform: empty image or input size");
  }
  InputTransform t;
  t.image_size = image_size;
  t.input_size = input_size;
  if (mode == ResizeMode::kStretch)
  {
    t.resized_width = input_size.width;
    t.resized_height = input_size.height;
  }
  else
  {
    const double scale = std::min(static_cast<double>(input_size.width) / image_size.width,
                                  static_cast<double>(input_size.height) / image_size.height);
    t.resized_width =
        std::clamp(static_cast<int>(std::lround(image_size.width * scale)), 1, input_size.width);
    t.resized_height =
        std::clamp(static_cast<int>(std::lround(image_size.height * scale)), 1, input_size.height);
    t.pad_x = (input_size.width - t.resized_width) / 2;
    t.pad_y = (input_size.height - t.resized_height) / 2;
  }
  t.scale_x = static_cast<double>(t.resized_width) / image_size.width;
  t.scale_y = static_cast<double>(t.resized_height) / image_size.height;
  return t;
}

BoundingBox InputTransform::toImage(double x_min, double y_min, double x_max, double y_max) const
{
  auto clip = [](double value, int limit)
  { return static_cast<float>(std::clamp(value, 0.0, double(limit))); };
  BoundingBox box;
  box.x_min = clip((x_min - pad_x) / scale_x, image_size.width);
  box.x_max = clip((x_max - pad_x) / scale_x, image_size.width);
  box.y_min = clip((y_min - pad_y) / scale_y, image_size.height);
  box.y_max = clip((y_max - pad_y) / scale_y, image_size.height);
  return box;
}

std::vector<YoloCandidate> decodeYoloOutputs(const std::vector<cv::Mat>& outputs, YoloOutputLayout layout,
                                             cv::Size input_size, int num_classes, double score_threshold)
{
  const int columns = 5 + num_classes;
  std::vector<YoloCandidate> candidates;
  for (const cv::Mat& output : outputs)
  {
    if (output.empty())
    {
      continue;
    }
    if (output.depth() != CV_32F || output.size[output.dims - 1] != columns)
    {
      throw std::invalid_argument("YOLO output blob of " + std::to_string(output.size[output.dims - 1]) +
                                  " float columns per box, expected 5 + " + std::to_string(num_classes) +
                                  " classes = " + std::to_string(columns));
    }
    const cv::Mat rows = output.isContinuous() ? output : output.clone();
    const std::size_t count = rows.total() / static_cast<std::size_t>(columns);
    const float* data = rows.ptr<float>();
    const double sx = layout == YoloOutputLayout::kOpenCvRegion ? input_size.width : 1.0;
    const double sy = layout == YoloOutputLayout::kOpenCvRegion ? input_size.height : 1.0;
    for (std::size_t r = 0; r < count; ++r)
    {
      const float* row = data + r * static_cast<std::size_t>(columns);
      const float objectness = row[4];
      if (!(objectness > 0.F) || !std::isfinite(row[0]) || !std::isfinite(row[1]) || !std::isfinite(row[2]) ||
          !std::isfinite(row[3]))
      {
        continue;
      }
      const double w = row[2] * sx;
      const double h = row[3] * sy;
      const cv::Rect2d box(row[0] * sx - w / 2.0, row[1] * sy - h / 2.0, w, h);
      for (int c = 0; c < num_classes; ++c)
      {
        const float score = layout == YoloOutputLayout::kOpenCvRegion ? row[5 + c] : objectness * row[5 + c];
        if (score > 0.F && score >= score_threshold && std::isfinite(score))
        {
          candidates.push_back({c, score, box});
        }
      }
    }
  }
  return candidates;
}

std::vector<YoloCandidate> suppressPerClass(const std::vector<YoloCandidate>& candidates,
                                            double score_threshold, double nms_threshold)
{
  std::map<int, std::vector<std::size_t>> by_class;
  for (std::size_t i = 0; i < candidates.size(); ++i)
  {
    by_class[candidates[i].class_id].push_back(i);
  }
  std::vector<YoloCandidate> kept;
  for (const auto& entry : by_class)
  {
    std::vector<cv::Rect2d> boxes;
    std::vector<float> scores;
    for (std::size_t i : entry.second)
    {
      boxes.push_back(candidates[i].box);
      scores.push_back(candidates[i].score);
    }
    std::vector<int> indices;
    cv::dnn::NMSBoxes(boxes, scores, static_cast<float>(score_threshold), static_cast<float>(nms_threshold),
                      indices);
    for (int index : indices)
    {
      kept.push_back(candidates[entry.second[static_cast<std::size_t>(index)]]);
    }
  }
  return kept;
}

YoloDetector::YoloDetector(const YoloDetectorConfig& config) : config_(config)
{
  config_.validate();
  class_names_ = readClassNames(config_.class_names_path);
  // OpenCV creates the layers at the first forward pass: the scope lasts until the probe below.
  const WinogradConvolutionScope winograd(config_.winograd && config_.backend == "opencv" &&
                                          config_.target == "cpu");
  winograd_used_ = winograd.active();
  const bool darknet = modelFormat(config_.model_path) == ModelFormat::kDarknet;
  try
  {
    if (darknet)
    {
      const DarknetCfgInfo info = parseDarknetCfg(config_.model_path);
      if (info.yolo_layers == 0)
      {
        throw YoloModelError(config_.model_path + ": the Darknet cfg has no [yolo] or [region] output layer");
      }
      if (info.num_classes != static_cast<int>(class_names_.size()))
      {
        throw YoloModelError(config_.class_names_path + ": lists " + std::to_string(class_names_.size()) +
                             " classes, but " + config_.model_path +
                             " has classes=" + std::to_string(info.num_classes));
      }
      checkDarknetWeights(config_.weights_path, config_.model_path, info);
      input_size_ = config_.input_width > 0 ? cv::Size(config_.input_width, config_.input_height)
                                            : cv::Size(info.input_width, info.input_height);
      layout_ = YoloOutputLayout::kOpenCvRegion;
      net_ = cv::dnn::readNetFromDarknet(config_.model_path, config_.weights_path);
    }
    else
    {
      input_size_ = onnxInputSize(readOnnxInput(config_.model_path));
      layout_ = config_.onnx_layout;
      net_ = cv::dnn::readNetFromONNX(config_.model_path);
    }
  }
  catch (const cv::Exception& e)
  {
    throw YoloModelError(config_.model_path + ": OpenCV cannot load the model" +
                         (darknet ? " with " + config_.weights_path : std::string()) + ": " + e.what());
  }
  if (net_.empty())
  {
    throw YoloModelError(config_.model_path + ": OpenCV loaded an empty network");
  }
  output_names_ = net_.getUnconnectedOutLayersNames();
  selectBackend();

  // One forward pass on a grey input: allocates the layers (so the first frame is not slow),
  // proves the backend works and checks the output width against the class names.
  const cv::Mat probe(input_size_, CV_8UC3, cv::Scalar::all(127));
  InputTransform transform;
  std::vector<cv::Mat> outputs;
  for (int attempt = 0; attempt < 2; ++attempt)
  {
    try
    {
      net_.setInput(makeInputBlob(probe, PixelFormat::kBgr8, transform));
      net_.forward(outputs, output_names_);
      break;
    }
    catch (const cv::Exception& e)
    {
      if (attempt == 0 && (backend_used_ != "opencv" || target_used_ != "cpu"))
      {
        warnings_.push_back("forward pass on backend " + backendDescription() + " failed (" + e.what() +
                            "); falling back to opencv/cpu");
        backend_used_ = "opencv";
        target_used_ = "cpu";
        net_.setPreferableBackend(cv::dnn::DNN_BACKEND_OPENCV);
        net_.setPreferableTarget(cv::dnn::DNN_TARGET_CPU);
        continue;
      }
      throw YoloModelError(config_.model_path + ": forward pass at input " +
                           std::to_string(input_size_.width) + "x" + std::to_string(input_size_.height) +
                           " failed: " + e.what());
    }
  }
  for (const cv::Mat& output : outputs)
  {
    const int columns = output.size[output.dims - 1];
    if (columns != 5 + static_cast<int>(class_names_.size()))
    {
      throw YoloModelError(config_.class_names_path + ": lists " + std::to_string(class_names_.size()) +
                           " classes, but " + config_.model_path + " outputs " + std::to_string(columns) +
                           " values per box (5 + " + std::to_string(columns - 5) + " classes)");
    }
  }
}

cv::Size YoloDetector::onnxInputSize(const OnnxInputInfo& input) const
{
  const cv::Size given(config_.input_width, config_.input_height);
  const cv::Size declared = input.imageSize();
  const auto text = [](cv::Size size)
  { return std::to_string(size.width) + "x" + std::to_string(size.height); };
  std::string shape;
  for (const long long dim : input.shape)
  {
    shape += (shape.empty() ? "" : ", ") + (dim > 0 ? std::to_string(dim) : std::string("?"));
  }
  const std::string declaration = "input \"" + input.name + "\" [" + shape + "]";
  if (declared.empty() && given.area() == 0)
  {
    throw YoloModelError(config_.model_path + ": the model's " + declaration +
                         " leaves its image size open: give the input size it was exported for");
  }
  if (!declared.empty() && given.area() > 0 && given != declared)
  {
    throw YoloModelError(config_.model_path + ": the model declares its " + declaration + ", an input of " +
                         text(declared) + ", but the input size given is " + text(given) + ": give " +
                         text(declared) + " or no size at all");
  }
  return declared.empty() ? given : declared;
}

void YoloDetector::selectBackend()
{
  const int backend = backendId(config_.backend);
  const int target = targetId(config_.target);
  const std::vector<cv::dnn::Target> available =
      cv::dnn::getAvailableTargets(static_cast<cv::dnn::Backend>(backend));
  if (std::find(available.begin(), available.end(), target) == available.end())
  {
    warnings_.push_back("DNN backend/target " + config_.backend + "/" + config_.target +
                        " is not available in this OpenCV build; falling back to opencv/cpu");
    backend_used_ = "opencv";
    target_used_ = "cpu";
  }
  else
  {
    backend_used_ = config_.backend;
    target_used_ = config_.target;
  }
  net_.setPreferableBackend(backendId(backend_used_));
  net_.setPreferableTarget(targetId(target_used_));
}

std::string YoloDetector::backendDescription() const
{
  return backend_used_ + "/" + target_used_;
}

std::string YoloDetector::description() const
{
  return config_.model_path + " (" + std::to_string(class_names_.size()) + " classes), input " +
         std::to_string(input_size_.width) + "x" + std::to_string(input_size_.height) + " " +
         toString(config_.resize_mode) + ", " + backendDescription() +
         (winograd_used_ ? ", Winograd 3x3" : "");
}

std::int64_t YoloDetector::flops()
{
  return net_.getFLOPS(cv::dnn::MatShape{1, 3, input_size_.height, input_size_.width});
}

void YoloDetector::setThresholds(double score_threshold, double nms_threshold)
{
  YoloDetectorConfig updated = config_;
  updated.score_threshold = score_threshold;
  updated.nms_threshold = nms_threshold;
  updated.validate();
  config_ = updated;
}

cv::Mat YoloDetector::makeInputBlob(const cv::Mat& image, PixelFormat format, InputTransform& transform) const
{
  if (image.empty())
  {
    throw std::invalid_argument("detect: empty image");
  }
  const int expected_type = format == PixelFormat::kMono8 ? CV_8UC1 : CV_8UC3;
  if (image.type() != expected_type)
  {
    throw std::invalid_argument(
        std::string("detect: image of OpenCV type ") + cv::typeToString(image.type()) +
        " does not match its pixel format (expected " + cv::typeToString(expected_type) + ")");
  }
  cv::Mat three_channel = image;
  bool image_rgb = format == PixelFormat::kRgb8;
  if (format == PixelFormat::kMono8)
  {
    cv::cvtColor(image, three_channel, cv::COLOR_GRAY2RGB);
    image_rgb = true;
  }
  transform = InputTransform::make(image.size(), input_size_, config_.resize_mode);
  cv::Mat resized;
  cv::resize(three_channel, resized, cv::Size(transform.resized_width, transform.resized_height), 0.0, 0.0,
             cv::INTER_LINEAR);
  cv::Mat canvas(input_size_, CV_32FC3, cv::Scalar::all(0.5));
  resized.convertTo(canvas(cv::Rect(static_cast<int>(transform.pad_x), static_cast<int>(transform.pad_y),
                                    transform.resized_width, transform.resized_height)),
                    CV_32F, 1.0 / 255.0);
  const bool swap_rb = image_rgb != config_.network_rgb;
  return cv::dnn::blobFromImage(canvas, 1.0, cv::Size(), cv::Scalar(), swap_rb, false, CV_32F);
}

std::vector<Detection> YoloDetector::detect(const cv::Mat& image, PixelFormat format)
{
  InputTransform transform;
  net_.setInput(makeInputBlob(image, format, transform));
  std::vector<cv::Mat> outputs;
  net_.forward(outputs, output_names_);
  const std::vector<YoloCandidate> kept =
      suppressPerClass(decodeYoloOutputs(outputs, layout_, input_size_, static_cast<int>(class_names_.size()),
                                         config_.score_threshold),
                       config_.score_threshold, config_.nms_threshold);
  std::vector<Detection> detections;
  for (const YoloCandidate& candidate : kept)
  {
    Detection detection;
    detection.class_id = static_cast<std::uint32_t>(candidate.class_id);
    detection.label = class_names_[static_cast<std::size_t>(candidate.class_id)];
    detection.score = candidate.score;
    detection.box = transform.toImage(candidate.box.x, candidate.box.y, candidate.box.x + candidate.box.width,
                                      candidate.box.y + candidate.box.height);
    if (detection.box.x_max > detection.box.x_min && detection.box.y_max > detection.box.y_min)
    {
      detections.push_back(std::move(detection));
    }
  }
  return publishedDetections(std::move(detections), config_);
}

RiderMergeResult mergeRiders(std::vector<Detection> detections, const std::string& rider_class,
                             const std::map<std::string, std::string>& vehicle_labels)
{
  RiderMergeResult result;
  std::vector<std::size_t> vehicles;
  std::vector<std::size_t> riders;
  for (std::size_t i = 0; i < detections.size(); ++i)
  {
    if (vehicle_labels.count(detections[i].label) != 0)
    {
      vehicles.push_back(i);
    }
    else if (detections[i].label == rider_class)
    {
      riders.push_back(i);
    }
  }
  std::stable_sort(vehicles.begin(), vehicles.end(),
                   [&](std::size_t a, std::size_t b) { return detections[a].score > detections[b].score; });
  std::vector<bool> used(detections.size(), false);
  for (const std::size_t v : vehicles)
  {
    const BoundingBox& vehicle = detections[v].box;
    const double rides_below = vehicle.y_min + 0.2 * (vehicle.y_max - vehicle.y_min);
    double widest = 0.0;
    std::size_t best = detections.size();
    for (const std::size_t r : riders)
    {
      const BoundingBox& rider = detections[r].box;
      const double centre = 0.5 * (rider.x_min + rider.x_max);
      const double overlap = std::min(rider.x_max, vehicle.x_max) - std::max(rider.x_min, vehicle.x_min);
      if (!used[r] && centre >= vehicle.x_min && centre <= vehicle.x_max && rider.y_min < vehicle.y_min &&
          rider.y_max > rides_below && overlap > widest)
      {
        widest = overlap;
        best = r;
      }
    }
    if (best == detections.size())
    {
      continue;
    }
    used[v] = used[best] = true;
    Detection merged = detections[v];
    const BoundingBox& rider = detections[best].box;
    merged.label = vehicle_labels.at(detections[v].label);
    merged.score = std::max(detections[v].score, detections[best].score);
    merged.box = {std::min(vehicle.x_min, rider.x_min), std::min(vehicle.y_min, rider.y_min),
                  std::max(vehicle.x_max, rider.x_max), std::max(vehicle.y_max, rider.y_max)};
    result.riders.push_back(std::move(merged));
  }
  for (std::size_t i = 0; i < detections.size(); ++i)
  {
    if (!used[i])
    {
      result.others.push_back(std::move(detections[i]));
    }
  }
  return result;
}

std::vector<Detection> publishedDetections(std::vector<Detection> detections,
                                           const YoloDetectorConfig& config)
{
  RiderMergeResult merged = mergeRiders(std::move(detections), config.rider_class, config.rider_merge);
  std::vector<Detection> published = std::move(merged.riders);
  for (Detection& detection : merged.others)
  {
    if (!config.class_map.empty())
    {
      const auto it = config.class_map.find(detection.label);
      if (it == config.class_map.end())
      {
        continue;
      }
      detection.label = it->second;
    }
    published.push_back(std::move(detection));
  }
  std::stable_sort(published.begin(), published.end(),
                   [](const Detection& a, const Detection& b) { return a.score > b.score; });
  return published;
}

void drawDetections(cv::Mat& image, const std::vector<Detection>& detections)
{
  static const cv::Scalar kPalette[] = {{0, 200, 255}, {255, 128, 0}, {0, 255, 0},   {255, 0, 255},
                                        {0, 0, 255},   {255, 255, 0}, {128, 0, 255}, {0, 128, 255}};
  for (const Detection& d : detections)
  {
    const cv::Scalar colour = kPalette[d.class_id % (sizeof(kPalette) / sizeof(kPalette[0]))];
    const cv::Point top_left(static_cast<int>(std::lround(d.box.x_min)),
                             static_cast<int>(std::lround(d.box.y_min)));
    const cv::Point bottom_right(static_cast<int>(std::lround(d.box.x_max)),
                                 static_cast<int>(std::lround(d.box.y_max)));
    cv::rectangle(image, top_left, bottom_right, colour, 2);
    char text[96];
    std::snprintf(text, sizeof(text), "%s %.2f", d.label.c_str(), static_cast<double>(d.score));
    int baseline = 0;
    const cv::Size size = cv::getTextSize(text, cv::FONT_HERSHEY_SIMPLEX, 0.5, 1, &baseline);
    const cv::Point origin(top_left.x, std::max(size.height + 2, top_left.y - 3));
    cv::rectangle(image, origin + cv::Point(0, baseline), origin + cv::Point(size.width, -size.height - 2),
                  colour, cv::FILLED);
    cv::putText(image, text, origin, cv::FONT_HERSHEY_SIMPLEX, 0.5, cv::Scalar(0, 0, 0), 1, cv::LINE_AA);
  }
}

}  // namespace grid_vision_fusion
