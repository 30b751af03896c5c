// Fuzz harness: the size check of a Darknet weights file against its cfg; the input is the cfg,
// the part separator, then the weights.
#include <sstream>

#include "fuzz_input.h"
#include "grid_vision_fusion/detection/yolo_detector.h"

GVF_FUZZ_TARGET(darknet_weights)
{
  const std::vector<std::string> files = gvf_fuzz::parts(data, size, 2);
  std::istringstream cfg(files[0]);
  std::istringstream weights(files[1], std::ios::binary);
  try
  {
    const grid_vision_fusion::DarknetCfgInfo info = grid_vision_fusion::parseDarknetCfg(cfg, "cfg");
    grid_vision_fusion::checkDarknetWeights(weights, "weights", "cfg", info);
  }
  catch (const grid_vision_fusion::YoloModelError&)
  {
  }
  return 0;
}
