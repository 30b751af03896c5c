#include "grid_vision_fusion/cli/model_options.h"

#include <stdexcept>

namespace grid_vision_fusion
{
namespace
{
bool endsWith(const std::string& text, const std::string& suffix)
{
  return text.size() >= suffix.size() &&
         text.compare(text.size() - suffix.size(), suffix.size(), suffix) == 0;
}
}  // namespace

void checkModelOptions(const std::string& model, const std::string& weights)
{
  if (endsWith(model, ".cfg"))
  {
    if (weights.empty())
    {
      throw std::invalid_argument("--model " + model +
                                  " is a Darknet cfg: give its .weights file with --weights");
    }
  }
  else if (endsWith(model, ".onnx"))
  {
    if (!weights.empty())
    {
      throw std::invalid_argument("--weights " + weights + " is not used with an ONNX --model (" + model +
                                  " holds its weights): leave it out");
    }
  }
  else
  {
    throw std::invalid_argument("--model must name a Darknet .cfg or an .onnx file, got \"" + model + "\"");
  }
}

}  // namespace grid_vision_fusion
