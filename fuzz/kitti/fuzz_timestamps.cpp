// Fuzz harness: KITTI raw timestamps.txt files.
#include <sstream>
#include <stdexcept>

#include "fuzz_input.h"
#include "grid_vision_fusion/kitti/kitti_raw.h"

GVF_FUZZ_TARGET(timestamps)
{
  std::istringstream input(gvf_fuzz::text(data, size));
  try
  {
    grid_vision_fusion::parseTimestamps(input, "fuzz");
  }
  catch (const std::runtime_error&)
  {
  }
  return 0;
}
