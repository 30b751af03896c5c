// Fuzz harness: KITTI tracking benchmark label files (label_02/NNNN.txt), parseTrackingLabels().
#include <sstream>

#include "fuzz_input.h"
#include "grid_vision_fusion/evaluation/kitti_ground_truth.h"

GVF_FUZZ_TARGET(tracking_labels)
{
  std::istringstream input(gvf_fuzz::text(data, size));
  try
  {
    grid_vision_fusion::parseTrackingLabels(input, "fuzz");
  }
  catch (const grid_vision_fusion::KittiLabelError&)
  {
  }
  return 0;
}
