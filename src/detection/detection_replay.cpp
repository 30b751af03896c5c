#include "grid_vision_fusion/detection/detection_replay.h"

#include <algorithm>
#include <cctype>
#include <cstdio>
#include <filesystem>
#include <stdexcept>

namespace grid_vision_fusion
{
namespace
{
/// Longest file pattern: with a width of at most two digits, every file name fits pathOf()'s buffer.
constexpr std::size_t kMaxPatternLength = 128;

/// Whether `pattern` holds exactly one integer conversion (%d or %i with flags and a width of at
/// most two digits) and no other conversion than "%%".
bool isFramePattern(const std::string& pattern)
{
  if (pattern.size() > kMaxPatternLength)
  {
    return false;
  }
  int conversions = 0;
  for (std::size_t i = 0; i < pattern.size(); ++i)
  {
    if (pattern[i] != '%')
    {
      continue;
    }
    ++i;
    if (i < pattern.size() && pattern[i] == '%')
    {
      continue;
    }
    while (i < pattern.size() &&
           (pattern[i] == '0' || pattern[i] == '-' || pattern[i] == '+' || pattern[i] == ' '))
    {
      ++i;
    }
    const std::size_t width_begin = i;
    while (i < pattern.size() && std::isdigit(static_cast<unsigned char>(pattern[i])))
    {
      ++i;
    }
    if (i - width_begin > 2)
    {
      return false;
    }
    if (i >= pattern.size() || (pattern[i] != 'd' && pattern[i] != 'i'))
    {
      return false;
    }
    ++conversions;
  }
  return conversions == 1;
}

}  // namespace

FrameIndexSource frameIndexSourceFromString(const std::string& name)
{
  if (name == "counter")
  {
    return FrameIndexSource::kCounter;
  }
  if (name == "seq")
  {
    return FrameIndexSource::kHeaderSeq;
  }
  throw std::invalid_argument("frame index source must be \"counter\" or \"seq\", got \"" + name + "\"");
}

std::string toString(FrameIndexSource source)
{
  return source == FrameIndexSource::kCounter ? "counter" : "seq";
}

const std::vector<std::string>& kittiObjectTypes()
{
  static const std::vector<std::string> kTypes{"Car",     "Van",  "Truck", "Pedestrian", "Person_sitting",
                                               "Cyclist", "Tram", "Misc",  "DontCare"};
  return kTypes;
}

void DetectionReplayConfig::validate() const
{
  if (directory.empty())
  {
    throw std::invalid_argument("replay directory must be set");
  }
  if (!isFramePattern(file_pattern))
  {
    throw std::invalid_argument(
        "replay file_pattern must hold exactly one integer conversion such as %06d (width at most 99, "
        "pattern at most " +
        std::to_string(kMaxPatternLength) + " characters), got \"" + file_pattern + "\"");
  }
  if (index_source == FrameIndexSource::kCounter && first_index < 0)
  {
    throw std::invalid_argument("replay first_index must be >= 0 with the counter, got " +
                                std::to_string(first_index));
  }
  if (!(default_score >= 0.0 && default_score <= 1.0))
  {
    throw std::invalid_argument("replay default_score must be in [0, 1], got " +
                                std::to_string(default_score));
  }
  if (!(score_threshold >= 0.0 && score_threshold <= 1.0))
  {
    throw std::invalid_argument("replay score_threshold must be in [0, 1], got " +
                                std::to_string(score_threshold));
  }
  for (const auto& entry : class_map)
  {
    if (entry.first.empty() || entry.second.empty())
    {
      throw std::invalid_argument("replay class_map entries must have non-empty names, got \"" + entry.first +
                                  "\" -> \"" + entry.second + "\"");
    }
  }
  noise.validate();
}

DetectionReplay::DetectionReplay(const DetectionReplayConfig& config) : config_(config)
{
  config_.validate();
  std::error_code error;
  if (!std::filesystem::is_directory(config_.directory, error))
  {
    throw std::invalid_argument("replay directory " + config_.directory +
                                " does not exist or is not a directory");
  }
  counter_ = config_.first_index;
}

std::int64_t DetectionReplay::nextFrameIndex(std::uint32_t header_seq)
{
  const std::int64_t index = config_.index_source == FrameIndexSource::kCounter
                                 ? counter_++
                                 : static_cast<std::int64_t>(header_seq) + config_.first_index;
  if (index < 0)
  {
    throw std::out_of_range("frame index " + std::to_string(index) + " (seq " + std::to_string(header_seq) +
                            " + first_index " + std::to_string(config_.first_index) + ") is negative");
  }
  return index;
}

std::string DetectionReplay::pathOf(std::int64_t frame_index) const
{
  char name[256];
  std::snprintf(name, sizeof(name), config_.file_pattern.c_str(), static_cast<int>(frame_index));
  return (std::filesystem::path(config_.directory) / name).string();
}

std::vector<Detection> DetectionReplay::detectionsOf(std::int64_t frame_index, std::uint32_t image_width,
                                                     std::uint32_t image_height) const
{
  const std::string path = pathOf(frame_index);
  std::error_code error;
  if (config_.missing_file_is_empty && !std::filesystem::exists(path, error))
  {
    return {};
  }
  const std::vector<KittiObjectLabel> labels = readKittiLabels(path);
  const auto& types = kittiObjectTypes();
  std::vector<Detection> detections;
  std::vector<NoiseLabel> noisy;
  for (std::size_t line = 0; line < labels.size(); ++line)
  {
    const KittiObjectLabel& label = labels[line];
    std::string name;
    if (config_.class_map.empty())
    {
      if (label.type == "DontCare")
      {
        continue;
      }
      name = label.type;
      std::transform(name.begin(), name.end(), name.begin(),
                     [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
    }
    else
    {
      const auto it = config_.class_map.find(label.type);
      if (it == config_.class_map.end())
      {
        continue;
      }
      name = it->second;
    }
    const double score = label.score ? static_cast<double>(*label.score) : config_.default_score;
    if (score < config_.score_threshold && !config_.noise.enabled)
    {
      continue;
    }
    Detection detection;
    detection.class_id =
        static_cast<std::uint32_t>(std::find(types.begin(), types.end(), label.type) - types.begin());
    detection.label = name;
    detection.score = static_cast<float>(score);
    detection.box = {label.left, label.top, label.right, label.bottom};
    if (image_width > 0 && image_height > 0)
    {
      detection.box = detection.box.clippedTo(image_width, image_height);
    }
    if (detection.box.x_max > detection.box.x_min && detection.box.y_max > detection.box.y_min)
    {
      if (config_.noise.enabled)
      {
        noisy.push_back({std::move(detection), label.truncated, label.occluded, line});
      }
      else
      {
        detections.push_back(std::move(detection));
      }
    }
  }
  if (config_.noise.enabled)
  {
    for (Detection& detection :
         applyDetectionNoise(config_.noise, frame_index, noisy, image_width, image_height))
    {
      if (detection.score >= config_.score_threshold)
      {
        detections.push_back(std::move(detection));
      }
    }
  }
  return detections;
}

std::string DetectionReplay::description() const
{
  return "replay of " + config_.directory + "/" + config_.file_pattern + ", frame index from the " +
         toString(config_.index_source) +
         (config_.noise.enabled ? ", detector noise seed " + std::to_string(config_.noise.seed) : "");
}

void DetectionReplay::setScoreThreshold(double score_threshold)
{
  DetectionReplayConfig updated = config_;
  updated.score_threshold = score_threshold;
  updated.validate();
  config_.score_threshold = score_threshold;
}

}  // namespace grid_vision_fusion
