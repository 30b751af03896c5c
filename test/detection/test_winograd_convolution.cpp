// The Winograd 3 × 3 convolution against OpenCV's own, on Darknet networks with random weights
// written by the test: same outputs up to float rounding (batch normalisation and leaky ReLU
// fused, biases, zero padding and none, odd image sizes whose last tiles are cut), the same FLOP
// count, and the layers it must leave to OpenCV left there.
#include <gtest/gtest.h>

#include <opencv2/dnn.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "grid_vision_fusion/detection/winograd_convolution.h"
#include "grid_vision_fusion/detection/yolo_detector.h"
#include "tiny_darknet.h"

namespace grid_vision_fusion
{
namespace
{
struct ConvSpec
{
  int filters;
  int size;
  int stride;
  bool pad;
  bool batch_normalize;
  std::string activation;
};

/// Writes a Darknet cfg and weights file of the given convolution stack on 3 input channels with
/// random parameters, then `tail` (sections without weights); returns {cfg, weights}.
std::pair<std::string, std::string> writeNetwork(const std::vector<ConvSpec>& layers, std::uint64_t seed,
                                                 const std::string& tail = "")
{
  const std::string dir = test::makeTempDirectory();
  const std::string cfg_path = dir + "/net.cfg";
  const std::string weights_path = dir + "/net.weights";
  std::ofstream cfg(cfg_path);
  cfg << "[net]\nwidth=32\nheight=32\nchannels=3\n\n";
  std::ofstream weights(weights_path, std::ios::binary);
  const std::int32_t version[3] = {0, 2, 0};
  const std::int64_t seen = 0;
  weights.write(reinterpret_cast<const char*>(version), sizeof(version));
  weights.write(reinterpret_cast<const char*>(&seen), sizeof(seen));
  cv::RNG rng(seed);
  int channels = 3;
  const auto write = [&](int count, float low, float high)
  {
    for (int i = 0; i < count; ++i)
    {
      const float value = rng.uniform(low, high);
      weights.write(reinterpret_cast<const char*>(&value), sizeof(value));
    }
  };
  for (const ConvSpec& layer : layers)
  {
    cfg << "[convolutional]\n"
        << (layer.batch_normalize ? "batch_normalize=1\n" : "") << "filters=" << layer.filters
        << "\nsize=" << layer.size << "\nstride=" << layer.stride << "\npad=" << (layer.pad ? 1 : 0)
        << "\nactivation=" << layer.activation << "\n\n";
    write(layer.filters, -0.5F, 0.5F);  // biases (the shift when batch-normalised)
    if (layer.batch_normalize)
    {
      write(layer.filters, 0.5F, 1.5F);   // scales
      write(layer.filters, -0.2F, 0.2F);  // rolling means
      write(layer.filters, 0.5F, 2.0F);   // rolling variances
    }
    const float bound = 1.7F / std::sqrt(static_cast<float>(channels * layer.size * layer.size));
    write(layer.filters * channels * layer.size * layer.size, -bound, bound);
    channels = layer.filters;
  }
  cfg << tail;
  return {cfg_path, weights_path};
}

cv::Mat randomInput(int height, int width, std::uint64_t seed)
{
  cv::Mat blob(std::vector<int>{1, 3, height, width}, CV_32F);
  cv::RNG rng(seed);
  rng.fill(blob, cv::RNG::UNIFORM, 0.0, 1.0);
  return blob;
}

cv::Mat run(cv::dnn::Net& net, const cv::Mat& input)
{
  net.setInput(input);
  return net.forward().clone();
}

/// Largest absolute difference relative to the largest absolute value of `expected`.
double relativeError(const cv::Mat& actual, const cv::Mat& expected)
{
  EXPECT_EQ(actual.total(), expected.total());
  return cv::norm(actual, expected, cv::NORM_INF) / std::max(1e-12, cv::norm(expected, cv::NORM_INF));
}

int countLayers(cv::dnn::Net& net, const std::string& type)
{
  int count = 0;
  for (const std::string& name : net.getLayerNames())
  {
    count += net.getLayer(net.getLayerId(name))->type == type ? 1 : 0;
  }
  return count;
}

struct Pair
{
  cv::dnn::Net own;       ///< OpenCV's convolutions
  cv::dnn::Net winograd;  ///< built and first run inside a WinogradConvolutionScope
};

Pair loadPair(const std::vector<ConvSpec>& layers, const cv::Mat& first_input)
{
  const auto files = writeNetwork(layers, 7);
  Pair pair;
  pair.own = cv::dnn::readNetFromDarknet(files.first, files.second);
  run(pair.own, first_input);
  {
    const WinogradConvolutionScope scope;
    EXPECT_TRUE(scope.active());
    pair.winograd = cv::dnn::readNetFromDarknet(files.first, files.second);
    run(pair.winograd, first_input);
  }
  return pair;
}

const std::vector<ConvSpec> kStack = {
    {16, 3, 1, true, true, "leaky"},    // 3 input channels: OpenCV's
    {32, 3, 1, true, true, "leaky"},    // Winograd, batch norm + leaky fused
    {24, 3, 1, true, false, "linear"},  // Winograd, own bias, no activation
    {20, 3, 1, false, true, "relu"},    // Winograd, no padding (output 2 px smaller), ReLU
    {16, 3, 2, true, true, "leaky"},    // stride 2: OpenCV's
    {8, 1, 1, true, false, "linear"},   // 1 × 1: OpenCV's
};

class WinogradConvolutionTest : public ::testing::Test
{
protected:
  void SetUp() override
  {
    if (!winogradSupported())
    {
      GTEST_SKIP() << "this CPU lacks AVX2/FMA: the detector keeps OpenCV's convolution";
    }
  }
};

TEST_F(WinogradConvolutionTest, SameOutputAsOpenCvOnOddSizes)
{
  const cv::Mat input = randomInput(37, 53, 1);
  Pair pair = loadPair(kStack, input);
  EXPECT_EQ(countLayers(pair.winograd, kWinogradLayerType), 3);
  EXPECT_EQ(countLayers(pair.own, kWinogradLayerType), 0);
  const cv::Mat expected = run(pair.own, input);
  const cv::Mat actual = run(pair.winograd, input);
  ASSERT_EQ(actual.size, expected.size);
  EXPECT_GT(cv::norm(expected, cv::NORM_INF), 0.1);
  EXPECT_LT(relativeError(actual, expected), 1e-5);
}

TEST_F(WinogradConvolutionTest, SameOutputAfterTheInputSizeChanges)
{
  // A new input size allocates the network again: the fused weights must not be fused twice.
  Pair pair = loadPair(kStack, randomInput(32, 32, 2));
  for (const cv::Size size : {cv::Size(21, 9), cv::Size(64, 48), cv::Size(5, 6)})
  {
    const cv::Mat input = randomInput(size.height, size.width, 3);
    EXPECT_LT(relativeError(run(pair.winograd, input), run(pair.own, input)), 1e-5) << size;
  }
}

TEST_F(WinogradConvolutionTest, ManyChannelsAndTilesSplitAcrossTasks)
{
  // Wide layers on a small image (few tile blocks: output channels split between tasks) and a
  // larger image (many blocks, a cut last block).
  const std::vector<ConvSpec> wide = {
      {64, 3, 1, true, true, "leaky"}, {200, 3, 1, true, true, "leaky"}, {70, 3, 1, true, true, "leaky"}};
  for (const cv::Size size : {cv::Size(13, 13), cv::Size(45, 31)})
  {
    const cv::Mat input = randomInput(size.height, size.width, 4);
    Pair pair = loadPair(wide, input);
    EXPECT_EQ(countLayers(pair.winograd, kWinogradLayerType), 2);
    EXPECT_LT(relativeError(run(pair.winograd, input), run(pair.own, input)), 1e-5) << size;
  }
}

TEST_F(WinogradConvolutionTest, SameFlopCountAsOpenCv)
{
  // The FLOP bound of a network must not depend on which layer computes its convolutions.
  Pair pair = loadPair(kStack, randomInput(32, 32, 5));
  const cv::dnn::MatShape shape{1, 3, 32, 32};
  EXPECT_GT(pair.own.getFLOPS(shape), 0);
  EXPECT_EQ(pair.winograd.getFLOPS(shape), pair.own.getFLOPS(shape));
}

TEST_F(WinogradConvolutionTest, ScopesNestAndEnd)
{
  const auto files = writeNetwork(kStack, 9);
  const cv::Mat input = randomInput(16, 16, 6);
  const auto winograd_layers = [&]()
  {
    cv::dnn::Net net = cv::dnn::readNetFromDarknet(files.first, files.second);
    run(net, input);
    return countLayers(net, kWinogradLayerType);
  };
  {
    const WinogradConvolutionScope off(false);
    EXPECT_FALSE(off.active());
    EXPECT_EQ(winograd_layers(), 0);
    const WinogradConvolutionScope outer;
    {
      const WinogradConvolutionScope inner;
      EXPECT_EQ(winograd_layers(), 3);
    }
    EXPECT_EQ(winograd_layers(), 3);  // the outer scope still holds the registration
  }
  EXPECT_EQ(winograd_layers(), 0);  // OpenCV's convolution is back
}

TEST_F(WinogradConvolutionTest, DetectorFindsTheSameBoxesEitherWay)
{
  // A small YOLO network whose middle layer is the Winograd layer's: the detector's default
  // (winograd: true) and OpenCV's convolution give the same detections.
  const auto files = writeNetwork(
      {{16, 3, 1, true, true, "leaky"}, {32, 3, 1, true, true, "leaky"}, {24, 1, 1, true, false, "linear"}},
      11, "[yolo]\nmask=0,1,2\nanchors=10,14, 23,27, 37,58\nclasses=3\nnum=3\n");
  const std::string names = std::filesystem::path(files.first).parent_path() / "net.names";
  std::ofstream(names) << "car\nperson\ntruck\n";
  YoloDetectorConfig config;
  config.model_path = files.first;
  config.weights_path = files.second;
  config.class_names_path = names;
  config.score_threshold = 0.3;
  cv::Mat image(48, 80, CV_8UC3);
  cv::RNG(12).fill(image, cv::RNG::UNIFORM, 0, 255);
  YoloDetector winograd(config);
  config.winograd = false;
  YoloDetector own(config);
  EXPECT_NE(winograd.description().find("Winograd"), std::string::npos) << winograd.description();
  EXPECT_EQ(own.description().find("Winograd"), std::string::npos) << own.description();
  const std::vector<Detection> expected = own.detect(image, PixelFormat::kBgr8);
  const std::vector<Detection> actual = winograd.detect(image, PixelFormat::kBgr8);
  ASSERT_FALSE(expected.empty())
      << "the random network must find something for the comparison to mean anything";
  ASSERT_EQ(actual.size(), expected.size());
  for (std::size_t i = 0; i < expected.size(); ++i)
  {
    EXPECT_EQ(actual[i].class_id, expected[i].class_id);
    EXPECT_NEAR(actual[i].score, expected[i].score, 1e-5);
    EXPECT_NEAR(actual[i].box.x_min, expected[i].box.x_min, 1e-3);
    EXPECT_NEAR(actual[i].box.y_max, expected[i].box.y_max, 1e-3);
  }
}

}  // namespace
}  // namespace grid_vision_fusion
