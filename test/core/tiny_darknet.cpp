#include "tiny_darknet.h"

#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <vector>

namespace grid_vision_fusion
{
namespace test
{
namespace
{
constexpr int kAnchors = 3;
// Batch normalisation of the BN variant; Darknet and OpenCV compute
// (x − mean) / sqrt(variance + ε) · scale + bias with a tiny ε (1e-6), negligible here.
constexpr float kBnScale = 2.F;
constexpr float kBnMean = 1.F;
constexpr float kBnVariance = 3.F;

std::string className(int c)
{
  static const char* const kNames[] = {"car", "person", "truck"};
  return c < 3 ? kNames[c] : "class" + std::to_string(c);
}

void writeFloats(std::ofstream& out, const std::vector<float>& values)
{
  out.write(reinterpret_cast<const char*>(values.data()),
            static_cast<std::streamsize>(values.size() * sizeof(float)));
}

}  // namespace

double sigmoid(double x)
{
  return 1.0 / (1.0 + std::exp(-x));
}

double expectedScore(const TinyDarknetSpec& spec, double r, double g, double b, int class_id)
{
  const double channel[3] = {r, g, b};
  const double objectness = sigmoid(spec.obj_gain * (r + g + b) + spec.obj_bias);
  return objectness * sigmoid(spec.class_gain * channel[class_id % 3] + spec.class_bias);
}

std::string makeTempDirectory()
{
  std::string pattern = (std::filesystem::temp_directory_path() / "gvf_yolo_XXXXXX").string();
  if (mkdtemp(pattern.data()) == nullptr)
  {
    throw std::runtime_error("cannot create a temporary directory from " + pattern);
  }
  return pattern;
}

TinyDarknetFiles writeTinyDarknet(const std::string& directory, const TinyDarknetSpec& spec)
{
  const int per_anchor = 5 + spec.num_classes;
  const int filters = kAnchors * per_anchor;
  TinyDarknetFiles files{directory + "/tiny.cfg", directory + "/tiny.weights", directory + "/tiny.names"};

  std::ofstream cfg(files.cfg);
  cfg << "# Tiny YOLO test model written by test/core/tiny_darknet.cpp\n"
      << "[net]\nbatch=1\nsubdivisions=1\nwidth=" << spec.width << "\nheight=" << spec.height
      << "\nchannels=3\n\n"
      << "[convolutional]\n"
      << (spec.batch_normalize ? "batch_normalize=1\n" : "") << "filters=" << filters
      << "\nsize=1\nstride=1\npad=0\nactivation=linear\n\n"
      << "[yolo]\nmask=0,1,2\nanchors=" << spec.anchor_w << "," << spec.anchor_h
      << ", 1,1, 1,1\nclasses=" << spec.num_classes
      << "\nnum=3\njitter=.3\nignore_thresh=.7\ntruth_thresh=1\nrandom=0\n";
  if (!cfg)
  {
    throw std::runtime_error("cannot write " + files.cfg);
  }

  std::ofstream names(files.names);
  for (int c = 0; c < spec.num_classes; ++c)
  {
    names << className(c) << "\n";
  }

  // The intended affine map per output channel: logit = Σ weight·input + bias.
  std::vector<float> biases(static_cast<std::size_t>(filters), 0.F);
  std::vector<float> weights(static_cast<std::size_t>(filters) * 3, 0.F);  // [filter][channel], 1×1 kernels
  for (int a = 0; a < kAnchors; ++a)
  {
    const int base = a * per_anchor;
    biases[base + 0] = spec.x_bias;
    biases[base + 1] = spec.y_bias;
    if (a != 0)
    {
      biases[base + 4] = -30.F;
      continue;
    }
    biases[base + 4] = spec.obj_bias;
    for (int ch = 0; ch < 3; ++ch)
    {
      weights[(base + 4) * 3 + ch] = spec.obj_gain;
    }
    for (int c = 0; c < spec.num_classes; ++c)
    {
      biases[base + 5 + c] = spec.class_bias;
      weights[(base + 5 + c) * 3 + (c % 3)] = spec.class_gain;
    }
  }

  std::ofstream out(files.weights, std::ios::binary);
  const std::int32_t version[3] = {0, spec.legacy_header ? 1 : 2, 0};
  out.write(reinterpret_cast<const char*>(version), sizeof(version));
  if (spec.legacy_header)
  {
    const std::int32_t seen = 0;
    out.write(reinterpret_cast<const char*>(&seen), sizeof(seen));
  }
  else
  {
    const std::uint64_t seen = 0;
    out.write(reinterpret_cast<const char*>(&seen), sizeof(seen));
  }
  if (spec.batch_normalize)
  {
    // y = (w'·x − mean)·scale/√var + bias' = w·x + b  ⇔  w' = w·√var/scale, bias' = b + mean·scale/√var.
    const float factor = kBnScale / std::sqrt(kBnVariance);
    std::vector<float> folded_biases(biases);
    std::vector<float> folded_weights(weights);
    for (std::size_t f = 0; f < biases.size(); ++f)
    {
      folded_biases[f] = biases[f] + kBnMean * factor;
      for (int ch = 0; ch < 3; ++ch)
      {
        folded_weights[f * 3 + ch] = weights[f * 3 + ch] / factor;
      }
    }
    writeFloats(out, folded_biases);
    writeFloats(out, std::vector<float>(biases.size(), kBnScale));
    writeFloats(out, std::vector<float>(biases.size(), kBnMean));
    writeFloats(out, std::vector<float>(biases.size(), kBnVariance));
    writeFloats(out, folded_weights);
  }
  else
  {
    writeFloats(out, biases);
    writeFloats(out, weights);
  }
  if (!out || !names)
  {
    throw std::runtime_error("cannot write " + files.weights + " or " + files.names);
  }
  return files;
}

}  // namespace test
}  // namespace grid_vision_fusion
