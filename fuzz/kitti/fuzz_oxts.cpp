// Fuzz harness: KITTI OXTS records, one per line, and the poses relative to the first.
#include <sstream>
#include <stdexcept>

#include "fuzz_input.h"
#include "grid_vision_fusion/kitti/kitti_raw.h"

GVF_FUZZ_TARGET(oxts)
{
  std::istringstream input(gvf_fuzz::text(data, size));
  std::vector<grid_vision_fusion::OxtsRecord> records;
  for (std::string line; std::getline(input, line);)
  {
    try
    {
      records.push_back(grid_vision_fusion::parseOxtsLine(line, "fuzz"));
    }
    catch (const std::runtime_error&)
    {
    }
  }
  grid_vision_fusion::oxtsPosesRelativeToFirst(records);
  return 0;
}
