// The model files the detector checks before OpenCV loads them: a Darknet cfg (its layers, their
// shapes and the parameters its weights file must hold), the size of a Darknet weights file, and
// the class names. (The declared input of an ONNX model: onnx_input.cpp.)
#include <cstdint>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "grid_vision_fusion/detection/yolo_detector.h"

namespace grid_vision_fusion
{
namespace
{
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
}  // namespace grid_vision_fusion
