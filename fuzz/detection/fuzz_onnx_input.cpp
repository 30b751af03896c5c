// Fuzz harness: the declared input of an ONNX model, parseOnnxInput().
#include "fuzz_input.h"
#include "grid_vision_fusion/detection/yolo_detector.h"

GVF_FUZZ_TARGET(onnx_input)
{
  try
  {
    grid_vision_fusion::parseOnnxInput(gvf_fuzz::text(data, size), "fuzz").imageSize();
  }
  catch (const grid_vision_fusion::YoloModelError&)
  {
  }
  return 0;
}
