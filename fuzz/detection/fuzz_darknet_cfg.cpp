// Fuzz harness: Darknet cfg files, parseDarknetCfg().
#include <sstream>

#include "fuzz_input.h"
#include "grid_vision_fusion/detection/yolo_detector.h"

GVF_FUZZ_TARGET(darknet_cfg)
{
  std::istringstream input(gvf_fuzz::text(data, size));
  try
  {
    grid_vision_fusion::parseDarknetCfg(input, "fuzz");
  }
  catch (const grid_vision_fusion::YoloModelError&)
  {
  }
  return 0;
}
