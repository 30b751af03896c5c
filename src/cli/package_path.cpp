#include "grid_vision_fusion/cli/package_path.h"

#include <ros/package.h>

#include <stdexcept>

namespace grid_vision_fusion
{
std::string packagePath(const std::string& what)
{
  const std::string package = ros::package::getPath("grid_vision_fusion");
  if (package.empty())
  {
    throw std::runtime_error(
        "cannot find the package grid_vision_fusion (source its setup.bash) for the default " + what +
        "; give it explicitly");
  }
  return package;
}

}  // namespace grid_vision_fusion
