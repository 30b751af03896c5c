// Reading private parameters into the core Config structs, refusing wrong types.
#pragma once

#include <ros/node_handle.h>

#include <stdexcept>
#include <string>

#include "grid_vision_fusion/core/fusion.h"

namespace grid_vision_fusion
{
/// Reads parameter `name` of `nh` into `value` when it is set; leaves `value` (the default)
/// untouched when it is not. @throws std::invalid_argument when it is set with a type that
/// does not convert to T (e.g. a string for a double), naming the parameter.
template <typename T>
void readParam(const ros::NodeHandle& nh, const std::string& name, T& value)
{
  if (!nh.hasParam(name))
  {
    return;
  }
  T read{};
  if (!nh.getParam(name, read))
  {
    throw std::invalid_argument("parameter " + nh.resolveName(name) + " has the wrong type");
  }
  value = read;
}

/// FusionConfig from the private parameters band_above, band_below, min_points, tie_rule,
/// exclusive_assignment. @throws std::invalid_argument on a wrong type or a value that
/// FusionConfig::validate() rejects.
FusionConfig fusionConfigFromParams(const ros::NodeHandle& nh);

}  // namespace grid_vision_fusion
