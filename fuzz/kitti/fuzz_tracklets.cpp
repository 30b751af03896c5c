// Fuzz harness: KITTI raw tracklet_labels.xml files.
#include <sstream>
#include <stdexcept>

#include "fuzz_input.h"
#include "grid_vision_fusion/kitti/kitti_raw.h"

GVF_FUZZ_TARGET(tracklets)
{
  std::istringstream input(gvf_fuzz::text(data, size));
  try
  {
    grid_vision_fusion::parseTracklets(input, "fuzz");
  }
  catch (const std::runtime_error&)
  {
  }
  return 0;
}
