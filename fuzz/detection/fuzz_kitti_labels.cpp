// Fuzz harness: KITTI object label files (label_2, detection results), parseKittiLabels().
#include <sstream>

#include "fuzz_input.h"
#include "grid_vision_fusion/detection/kitti_labels.h"

GVF_FUZZ_TARGET(kitti_labels)
{
  std::istringstream input(gvf_fuzz::text(data, size));
  try
  {
    grid_vision_fusion::parseKittiLabels(input, "fuzz");
  }
  catch (const grid_vision_fusion::KittiLabelError&)
  {
  }
  return 0;
}
