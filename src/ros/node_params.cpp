#include "grid_vision_fusion/ros/node_params.h"

#include <cmath>
#include <stdexcept>

namespace grid_vision_fusion
{
namespace
{
/// Reads an enumeration from its name with `parse`, which throws std::invalid_argument listing
/// the valid names.
template <typename Enum, typename Parse>
bool enumFromParam(const XmlRpc::XmlRpcValue& value, Enum& out, Parse parse)
{
  std::string name;
  if (!paramValueAs(value, name))
  {
    return false;
  }
  out = parse(name);
  return true;
}

/// @throws std::invalid_argument "parameter <name> <what>" unless `condition`.
void require(bool condition, const ParamSource& source, const std::string& name, const std::string& what)
{
  if (!condition)
  {
    throw std::invalid_argument("parameter " + source.describe(name) + " " + what);
  }
}

/// Visits `params` with a reader of `source`; hands the unknown names to `unknown`.
template <typename Params>
void readTable(Params& params, const ParamSource& source, std::vector<std::string>* unknown)
{
  ParamReader reader(source);
  visitParams(params, reader);
  if (unknown)
  {
    *unknown = reader.unknownParams();
  }
}
}  // namespace

bool paramValueAs(const XmlRpc::XmlRpcValue& value, TieRule& out)
{
  return enumFromParam(value, out, tieRuleFromString);
}
bool paramValueAs(const XmlRpc::XmlRpcValue& value, PositionSource& out)
{
  return enumFromParam(value, out, positionSourceFromString);
}
bool paramValueAs(const XmlRpc::XmlRpcValue& value, MotionVote& out)
{
  return enumFromParam(value, out, motionVoteFromString);
}
bool paramValueAs(const XmlRpc::XmlRpcValue& value, ResizeMode& out)
{
  return enumFromParam(value, out, resizeModeFromString);
}
bool paramValueAs(const XmlRpc::XmlRpcValue& value, YoloOutputLayout& out)
{
  return enumFromParam(value, out, yoloOutputLayoutFromString);
}
bool paramValueAs(const XmlRpc::XmlRpcValue& value, FrameIndexSource& out)
{
  return enumFromParam(value, out, frameIndexSourceFromString);
}
XmlRpc::XmlRpcValue toParamValue(TieRule value)
{
  return toParamValue(toString(value));
}
XmlRpc::XmlRpcValue toParamValue(PositionSource value)
{
  return toParamValue(toString(value));
}
XmlRpc::XmlRpcValue toParamValue(MotionVote value)
{
  return toParamValue(toString(value));
}
XmlRpc::XmlRpcValue toParamValue(ResizeMode value)
{
  return toParamValue(toString(value));
}
XmlRpc::XmlRpcValue toParamValue(YoloOutputLayout value)
{
  return toParamValue(toString(value));
}
XmlRpc::XmlRpcValue toParamValue(FrameIndexSource value)
{
  return toParamValue(toString(value));
}

bool paramValueAs(const XmlRpc::XmlRpcValue& value, std::map<std::string, Footprint>& out)
{
  if (value.getType() != XmlRpc::XmlRpcValue::TypeStruct)
  {
    return false;
  }
  auto& v = const_cast<XmlRpc::XmlRpcValue&>(value);
  std::map<std::string, Footprint> read;
  for (auto it = v.begin(); it != v.end(); ++it)
  {
    XmlRpc::XmlRpcValue& pair = it->second;
    double length = 0.0;
    double width = 0.0;
    if (pair.getType() != XmlRpc::XmlRpcValue::TypeArray || pair.size() != 2 ||
        !paramValueAs(pair[0], length) || !paramValueAs(pair[1], width))
    {
      throw std::invalid_argument("entry " + it->first + " must be [length, width] in metres");
    }
    read[it->first] = Footprint{length, width};
  }
  out = std::move(read);
  return true;
}

XmlRpc::XmlRpcValue toParamValue(const std::map<std::string, Footprint>& value)
{
  XmlRpc::XmlRpcValue out;
  out.begin();  // an (empty) struct
  for (const auto& [label, footprint] : value)
  {
    XmlRpc::XmlRpcValue pair;
    pair.setSize(2);
    pair[0] = footprint.length;
    pair[1] = footprint.width;
    out[label] = pair;
  }
  return out;
}

DynamicGridParams DynamicGridParams::fromParams(const ParamSource& source, std::vector<std::string>* unknown)
{
  DynamicGridParams p;
  readTable(p, source, unknown);
  require(!p.fixed_frame.empty(), source, "fixed_frame", "must not be empty");
  require(p.queue_size >= 1, source, "queue_size", "must be >= 1, got " + std::to_string(p.queue_size));
  require(p.expected_rate > 0.0 && std::isfinite(p.expected_rate), source, "expected_rate",
          "must be > 0 [Hz]");
  p.filter.validate();
  return p;
}

DetectorParams DetectorParams::fromParams(const ParamSource& source, std::vector<std::string>* unknown)
{
  DetectorParams p;
  readTable(p, source, unknown);
  p.replay.score_threshold = p.yolo.score_threshold;
  if (p.backend == "opencv_dnn")
  {
    p.yolo.validate();
  }
  else if (p.backend == "replay")
  {
    p.replay.validate();
  }
  else
  {
    require(false, source, "backend", "must be \"opencv_dnn\" or \"replay\", got \"" + p.backend + "\"");
  }
  return p;
}

GridProjectionParams GridProjectionParams::fromParams(const ParamSource& source,
                                                      std::vector<std::string>* unknown)
{
  GridProjectionParams p;
  readTable(p, source, unknown);
  require(std::isfinite(p.ground_height), source, "ground_height", "must be finite");
  require(std::isfinite(p.max_grid_age) && p.max_grid_age > 0.0, source, "max_grid_age",
          "must be finite and > 0 s, got " + std::to_string(p.max_grid_age));
  require(std::isfinite(p.grid_sync_tolerance), source, "grid_sync_tolerance",
          "must be finite (< 0: no waiting), got " + std::to_string(p.grid_sync_tolerance));
  require(p.image_cache_size >= 1, source, "image_cache_size",
          "must be >= 1, got " + std::to_string(p.image_cache_size));
  require(p.queue_size >= 1, source, "queue_size", "must be >= 1, got " + std::to_string(p.queue_size));
  p.projection.validate();
  return p;
}

FusionParams FusionParams::fromParams(const ParamSource& source, std::vector<std::string>* unknown)
{
  FusionParams p;
  readTable(p, source, unknown);
  require(p.queue_size >= 1, source, "queue_size", "must be >= 1, got " + std::to_string(p.queue_size));
  require(p.image_cache_size >= 1, source, "image_cache_size",
          "must be >= 1, got " + std::to_string(p.image_cache_size));
  p.fusion.validate();
  p.tracker.validate();
  return p;
}

std::vector<std::string> FusionParams::perFrameOptionsIgnored() const
{
  std::vector<std::string> warnings;
  if (!tracking)
  {
    return warnings;
  }
  const FusionConfig defaults;
  const auto ignored = [&](const std::string& key, const std::string& value)
  {
    warnings.push_back("~" + key + " is " + value +
                       ", but it only acts on the per-frame verdict of ~tracking: false (the paper's mode); "
                       "with tracking the track's motion model decides, and it is not used");
  };
  if (fusion.min_points != defaults.min_points)
  {
    ignored("min_points", std::to_string(fusion.min_points));
  }
  if (fusion.tie_rule != defaults.tie_rule)
  {
    ignored("tie_rule", toString(fusion.tie_rule));
  }
  return warnings;
}

}  // namespace grid_vision_fusion
