// Where the installed or sourced package lies, for the tools' defaults (config/, models/).
#pragma once

#include <string>

namespace grid_vision_fusion
{
/// The folder of the package grid_vision_fusion (ros::package::getPath()).
/// @throws std::runtime_error when ROS cannot find it, naming `what` (the option whose default
///         needs it, e.g. "--config") and saying to source setup.bash or to give it explicitly.
std::string packagePath(const std::string& what);

}  // namespace grid_vision_fusion
