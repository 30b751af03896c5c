#include "grid_vision_fusion/ros/params.h"

namespace grid_vision_fusion
{
FusionConfig fusionConfigFromParams(const ros::NodeHandle& nh)
{
  FusionConfig config;
  readParam(nh, "band_above", config.band_above);
  readParam(nh, "band_below", config.band_below);
  readParam(nh, "min_points", config.min_points);
  std::string tie_rule = toString(config.tie_rule);
  readParam(nh, "tie_rule", tie_rule);
  config.tie_rule = tieRuleFromString(tie_rule);
  readParam(nh, "exclusive_assignment", config.exclusive_assignment);
  config.validate();
  return config;
}

}  // namespace grid_vision_fusion
