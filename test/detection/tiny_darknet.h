// Test helper: writes a tiny YOLO model in the real Darknet formats (cfg text, binary weights)
// whose output is known by construction, plus its class names file.
//
// Network: [net] W×H×3 → [convolutional] 1×1, stride 1, 3·(5+C) filters, linear → [yolo] with
// three anchors (only anchor 0 can fire). The YOLO grid therefore equals the input grid: one
// cell per network input pixel. For a network input pixel with RGB values (r, g, b) in [0, 1]:
//   objectness logit     = obj_gain · (r + g + b) + obj_bias
//   class c logit        = class_gain · channel(c mod 3) + class_bias      (channel 0 = r)
//   x, y logits          = x_bias, y_bias      → centre (col + σ(x_bias), row + σ(y_bias))
//   w, h logits          = 0                   → box anchor_w × anchor_h network pixels
// Anchors 1 and 2 have objectness logit −30 everywhere.
// With the defaults a pure red pixel gives a class-0 box of score σ(10)·σ(10), a black pixel
// nothing, a white pixel one box of every class.
#pragma once

#include <string>

namespace grid_vision_fusion
{
namespace test
{
struct TinyDarknetSpec
{
  int width = 16;
  int height = 16;
  int num_classes = 3;
  float anchor_w = 4.F;  ///< [network px]
  float anchor_h = 2.F;  ///< [network px]
  float obj_gain = 20.F;
  float obj_bias = -10.F;
  float class_gain = 20.F;
  float class_bias = -10.F;
  float x_bias = 0.F;
  float y_bias = 0.F;
  /// Give the convolution batch normalisation (scale 2, mean 1, variance 3, folded so that the
  /// layer computes the same logits) to exercise the biases/scales/mean/variance/weights order.
  bool batch_normalize = false;
  /// Write a version-0.1 header (32-bit `seen`) instead of version 0.2 (64-bit `seen`).
  bool legacy_header = false;
};

struct TinyDarknetFiles
{
  std::string cfg;
  std::string weights;
  std::string names;
};

/// Writes <directory>/tiny.cfg, tiny.weights and tiny.names (classes "car", "person", "truck",
/// then "class3", ...). @throws std::runtime_error when a file cannot be written.
TinyDarknetFiles writeTinyDarknet(const std::string& directory, const TinyDarknetSpec& spec);

/// Logistic function.
double sigmoid(double x);

/// Score (objectness × class probability) the model gives class `class_id` at a network input
/// pixel of RGB values (r, g, b) in [0, 1].
double expectedScore(const TinyDarknetSpec& spec, double r, double g, double b, int class_id);

/// A fresh empty directory under the system temporary directory.
std::string makeTempDirectory();

}  // namespace test
}  // namespace grid_vision_fusion
