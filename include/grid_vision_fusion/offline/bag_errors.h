// The message of a bag that cannot be read, shared by the tools that read bags.
#pragma once

#include <filesystem>
#include <string>

namespace grid_vision_fusion
{
/// "<bag>: cannot read the bag (<what>); a bag whose recording was cut short is truncated and
/// unindexed: try `rosbag reindex <bag>`", or "<bag>: no such file" when there is none.
inline std::string bagReadError(const std::string& bag, const std::string& what)
{
  std::error_code error;
  if (!std::filesystem::exists(bag, error))
  {
    return bag + ": no such file";
  }
  if (std::filesystem::is_directory(bag, error))
  {
    return bag + ": is a folder, not a bag";
  }
  return bag + ": cannot read the bag (" + what +
         "); a bag whose recording was cut short is truncated and unindexed: try `rosbag reindex " + bag +
         "`";
}

}  // namespace grid_vision_fusion
