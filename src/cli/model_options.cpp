#include "grid_vision_fusion/cli/model_options.h"

#include <stdexcept>

#include "grid_vision_fusion/detection/yolo_detector.h"

namespace grid_vision_fusion
{
void checkModelOptions(const std::string& model, const std::string& weights)
{
  switch (modelFormat(model))
  {
    case ModelFormat::kDarknet:
      if (weights.empty())
      {
        throw std::invalid_argument("--model " + model +
                                    " is a Darknet cfg: give its .weights file with --weights");
      }
      break;
    case ModelFormat::kOnnx:
      if (!weights.empty())
      {
        throw std::invalid_argument("--weights " + weights + " is not used with an ONNX --model (" + model +
                                    " holds its weights): leave it out");
      }
      break;
    case ModelFormat::kUnknown:
      throw std::invalid_argument("--model must name a Darknet .cfg or an .onnx file, got \"" + model + "\"");
  }
}

}  // namespace grid_vision_fusion
