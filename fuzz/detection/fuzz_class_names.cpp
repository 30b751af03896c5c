// Fuzz harness: class name files (one name per line).
#include <sstream>

#include "fuzz_input.h"
#include "grid_vision_fusion/detection/yolo_detector.h"

GVF_FUZZ_TARGET(class_names)
{
  std::istringstream input(gvf_fuzz::text(data, size));
  try
  {
    grid_vision_fusion::parseClassNames(input, "fuzz");
  }
  catch (const grid_vision_fusion::YoloModelError&)
  {
  }
  return 0;
}
