// The tools' --model and --weights options, checked as the user typed them (before the detector's
// own check, whose messages name the YAML keys model and weights).
#pragma once

#include <string>

namespace grid_vision_fusion
{
/// @throws std::invalid_argument naming --model or --weights: a model that is neither a Darknet
///         .cfg nor an .onnx file, a .cfg without --weights, an .onnx with --weights.
void checkModelOptions(const std::string& model, const std::string& weights);

}  // namespace grid_vision_fusion
