#include "grid_vision_fusion/detection/kitti_results.h"

#include <algorithm>
#include <cctype>
#include <stdexcept>

#include "grid_vision_fusion/detection/detection_replay.h"

namespace grid_vision_fusion
{
std::string kittiTypeOfLabel(const std::string& label)
{
  if (label.empty())
  {
    throw std::invalid_argument("a detection label must not be empty");
  }
  const std::string lower = lowerCase(label);
  for (const std::string& type : kittiObjectTypes())
  {
    if (lowerCase(type) == lower)
    {
      return type;
    }
  }
  std::string type = label;
  std::replace_if(
      type.begin(), type.end(), [](unsigned char c) { return std::isspace(c) != 0; }, '_');
  return type;
}

KittiObjectLabel kittiResultOf(const Detection& detection)
{
  KittiObjectLabel label;
  label.type = kittiTypeOfLabel(detection.label);
  label.truncated = -1.F;
  label.occluded = -1;
  label.alpha = -10.F;
  label.left = detection.box.x_min;
  label.top = detection.box.y_min;
  label.right = detection.box.x_max;
  label.bottom = detection.box.y_max;
  label.height = -1.F;
  label.width = -1.F;
  label.length = -1.F;
  label.x = -1000.F;
  label.y = -1000.F;
  label.z = -1000.F;
  label.rotation_y = -10.F;
  label.score = detection.score;
  return label;
}

}  // namespace grid_vision_fusion
