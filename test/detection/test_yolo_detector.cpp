// YoloDetector with the tiny Darknet model of tiny_darknet.h, whose output is known by
// construction: loading, OpenCV's region-layer output format, decoding, scores, per-class NMS,
// letterbox and resize mapping, pixel formats, class filter, model file errors.
#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>

#include <filesystem>
#include <fstream>

#include "grid_vision_fusion/detection/yolo_detector.h"
#include "tiny_darknet.h"

namespace grid_vision_fusion
{
namespace
{
using test::expectedScore;
using test::sigmoid;
using test::TinyDarknetFiles;
using test::TinyDarknetSpec;

const std::string kModelDir = GVF_MODEL_DIR;
constexpr double kPixelTolerance = 1e-3;
constexpr double kScoreTolerance = 1e-4;

class YoloDetectorTest : public ::testing::Test
{
protected:
  void SetUp() override { directory_ = test::makeTempDirectory(); }
  void TearDown() override { std::filesystem::remove_all(directory_); }

  YoloDetectorConfig configFor(const TinyDarknetFiles& files) const
  {
    YoloDetectorConfig config;
    config.model_path = files.cfg;
    config.weights_path = files.weights;
    config.class_names_path = files.names;
    config.score_threshold = 0.3;
    config.nms_threshold = 0.45;
    return config;
  }

  YoloDetectorConfig tinyConfig(const TinyDarknetSpec& spec = TinyDarknetSpec())
  {
    return configFor(test::writeTinyDarknet(directory_, spec));
  }

  std::string directory_;
};

/// A black BGR image with the pixel (col, row) set to `bgr`.
cv::Mat imageWithPixel(cv::Size size, int col, int row, cv::Vec3b bgr)
{
  cv::Mat image(size, CV_8UC3, cv::Scalar::all(0));
  image.at<cv::Vec3b>(row, col) = bgr;
  return image;
}

void expectBox(const Detection& d, double x_min, double y_min, double x_max, double y_max)
{
  EXPECT_NEAR(d.box.x_min, x_min, kPixelTolerance);
  EXPECT_NEAR(d.box.y_min, y_min, kPixelTolerance);
  EXPECT_NEAR(d.box.x_max, x_max, kPixelTolerance);
  EXPECT_NEAR(d.box.y_max, y_max, kPixelTolerance);
}

TEST_F(YoloDetectorTest, OneBoxOfTheChosenClassAtTheChosenCell)
{
  YoloDetector detector(tinyConfig());
  EXPECT_EQ(detector.inputSize(), cv::Size(16, 16));
  ASSERT_EQ(detector.classNames(), (std::vector<std::string>{"car", "person", "truck"}));
  EXPECT_TRUE(detector.warnings().empty());
  // A dim red pixel (153 = 0.6 · 255) at column 5, row 7: objectness and class-0 logits are both
  // 20 · 0.6 − 10 = 2, so the score is σ(2)·σ(2) = 0.7758 (σ(2) alone would be 0.8808: this checks
  // that OpenCV's class columns already hold objectness × class probability).
  const auto detections = detector.detect(imageWithPixel({16, 16}, 5, 7, {0, 0, 153}), PixelFormat::kBgr8);
  ASSERT_EQ(detections.size(), 1U);
  EXPECT_EQ(detections[0].class_id, 0U);
  EXPECT_EQ(detections[0].label, "car");
  EXPECT_NEAR(detections[0].score, sigmoid(2.0) * sigmoid(2.0), kScoreTolerance);
  // Centre of the cell (5.5, 7.5), anchor 4 × 2 network pixels = image pixels here.
  expectBox(detections[0], 3.5, 6.5, 7.5, 8.5);
}

TEST_F(YoloDetectorTest, BoxOffsetFollowsTheXYLogits)
{
  TinyDarknetSpec spec;
  spec.x_bias = 1.F;
  spec.y_bias = -2.F;
  YoloDetector detector(tinyConfig(spec));
  const auto detections = detector.detect(imageWithPixel({16, 16}, 9, 3, {0, 0, 255}), PixelFormat::kBgr8);
  ASSERT_EQ(detections.size(), 1U);
  const double cx = 9 + sigmoid(1.0);
  const double cy = 3 + sigmoid(-2.0);
  expectBox(detections[0], cx - 2, cy - 1, cx + 2, cy + 1);
  EXPECT_NEAR(detections[0].score, expectedScore(spec, 1, 0, 0, 0), kScoreTolerance);
}

TEST_F(YoloDetectorTest, BatchNormalisedAndLegacyHeaderModelsGiveTheSameBox)
{
  TinyDarknetSpec spec;
  spec.batch_normalize = true;
  spec.legacy_header = true;
  YoloDetector detector(tinyConfig(spec));
  const auto detections = detector.detect(imageWithPixel({16, 16}, 5, 7, {0, 153, 0}), PixelFormat::kBgr8);
  ASSERT_EQ(detections.size(), 1U);
  EXPECT_EQ(detections[0].label, "person");
  EXPECT_NEAR(detections[0].score, sigmoid(2.0) * sigmoid(2.0), kScoreTolerance);
  expectBox(detections[0], 3.5, 6.5, 7.5, 8.5);
}

TEST_F(YoloDetectorTest, ChannelOrderOfEveryPixelFormat)
{
  YoloDetector detector(tinyConfig());
  // Red in RGB order is class 0; the same bytes read as BGR are blue, class 2.
  const cv::Mat bytes = imageWithPixel({16, 16}, 5, 7, {255, 0, 0});
  const auto as_rgb = detector.detect(bytes, PixelFormat::kRgb8);
  ASSERT_EQ(as_rgb.size(), 1U);
  EXPECT_EQ(as_rgb[0].label, "car");
  const auto as_bgr = detector.detect(bytes, PixelFormat::kBgr8);
  ASSERT_EQ(as_bgr.size(), 1U);
  EXPECT_EQ(as_bgr[0].label, "truck");
  // A white mono pixel fires every class at the same box: per-class NMS keeps all three.
  cv::Mat mono(16, 16, CV_8UC1, cv::Scalar(0));
  mono.at<std::uint8_t>(7, 5) = 255;
  const auto from_mono = detector.detect(mono, PixelFormat::kMono8);
  ASSERT_EQ(from_mono.size(), 3U);
  for (const Detection& d : from_mono)
  {
    expectBox(d, 3.5, 6.5, 7.5, 8.5);
    EXPECT_NEAR(d.score, sigmoid(50.0) * sigmoid(10.0), kScoreTolerance);
  }
}

TEST_F(YoloDetectorTest, OpenCvZeroesScoresBelowTheYoloLayerThresh)
{
  // Documented behaviour of OpenCV's region layer: class columns below the [yolo] `thresh`
  // (0.2 when the cfg has none) are zeroed, so even score_threshold 0 cannot see them.
  YoloDetectorConfig config = tinyConfig();
  config.score_threshold = 0.0;
  YoloDetector detector(config);
  // Red 122: logits 20·122/255 − 10 = −0.43, score σ(−0.43)² = 0.155 < 0.2: gone.
  EXPECT_TRUE(detector.detect(imageWithPixel({16, 16}, 5, 7, {0, 0, 122}), PixelFormat::kBgr8).empty());
  // Red 128: logits 0.039, score σ(0.039)² = 0.26 > 0.2: kept.
  const auto kept = detector.detect(imageWithPixel({16, 16}, 5, 7, {0, 0, 128}), PixelFormat::kBgr8);
  ASSERT_EQ(kept.size(), 1U);
  EXPECT_NEAR(kept[0].score, expectedScore(TinyDarknetSpec(), 128.0 / 255.0, 0, 0, 0), kScoreTolerance);
}

TEST_F(YoloDetectorTest, WrongImageTypeIsRefused)
{
  YoloDetector detector(tinyConfig());
  EXPECT_THROW(detector.detect(cv::Mat(16, 16, CV_8UC1, cv::Scalar(0)), PixelFormat::kBgr8),
               std::invalid_argument);
  EXPECT_THROW(detector.detect(cv::Mat(16, 16, CV_16UC3, cv::Scalar(0)), PixelFormat::kRgb8),
               std::invalid_argument);
  EXPECT_THROW(detector.detect(cv::Mat(), PixelFormat::kMono8), std::invalid_argument);
}

TEST_F(YoloDetectorTest, NmsSuppressesTheWeakerOverlappingBoxOfTheSameClass)
{
  YoloDetectorConfig config = tinyConfig();
  YoloDetector detector(config);
  // Neighbouring cells 5 and 6 of row 7: 4×2 boxes shifted by 1 px, IoU = 6 / 10 = 0.6.
  cv::Mat image = imageWithPixel({16, 16}, 5, 7, {0, 0, 255});
  image.at<cv::Vec3b>(7, 6) = {0, 0, 153};
  auto detections = detector.detect(image, PixelFormat::kBgr8);
  ASSERT_EQ(detections.size(), 1U) << "IoU 0.6 > 0.45: the weaker box must go";
  EXPECT_NEAR(detections[0].score, expectedScore(TinyDarknetSpec(), 1, 0, 0, 0), kScoreTolerance);
  expectBox(detections[0], 3.5, 6.5, 7.5, 8.5);

  detector.setThresholds(0.3, 0.65);
  detections = detector.detect(image, PixelFormat::kBgr8);
  ASSERT_EQ(detections.size(), 2U) << "IoU 0.6 < 0.65: both stay";
  EXPECT_GT(detections[0].score, detections[1].score) << "sorted by decreasing score";
  expectBox(detections[1], 4.5, 6.5, 8.5, 8.5);

  // Score threshold between the two scores (0.9999 and 0.7758).
  detector.setThresholds(0.8, 0.65);
  EXPECT_EQ(detector.detect(image, PixelFormat::kBgr8).size(), 1U);
  EXPECT_THROW(detector.setThresholds(1.5, 0.5), std::invalid_argument);
  EXPECT_THROW(detector.setThresholds(0.5, -0.1), std::invalid_argument);
}

TEST_F(YoloDetectorTest, NothingFoundInABlackImage)
{
  YoloDetector detector(tinyConfig());
  EXPECT_TRUE(detector.detect(cv::Mat(16, 16, CV_8UC3, cv::Scalar::all(0)), PixelFormat::kBgr8).empty());
}

TEST_F(YoloDetectorTest, LetterboxMapsBackToANonSquareImage)
{
  YoloDetectorConfig config = tinyConfig();
  // The grey (0.5) border fires every class with score σ(20)·σ(0) ≈ 0.5: stay above it.
  config.score_threshold = 0.6;
  YoloDetector detector(config);
  // 64 × 32 into 16 × 16: scale 1/4, resized 16 × 8, 4 grey rows above and below. A red 4×4
  // block at x ∈ [20, 24), y ∈ [8, 12) becomes network pixel (5, 2 + 4) exactly (bilinear
  // downscaling by 4 averages source pixels 4k+1 and 4k+2).
  cv::Mat image(32, 64, CV_8UC3, cv::Scalar::all(0));
  image(cv::Rect(20, 8, 4, 4)).setTo(cv::Scalar(0, 0, 255));
  const auto detections = detector.detect(image, PixelFormat::kBgr8);
  ASSERT_EQ(detections.size(), 1U);
  // Network box (3.5, 5.5)–(7.5, 7.5); image = (net − pad) · 4.
  expectBox(detections[0], 14.0, 6.0, 30.0, 14.0);
  EXPECT_NEAR(detections[0].score, expectedScore(TinyDarknetSpec(), 1, 0, 0, 0), kScoreTolerance);

  // A tall image pads left and right: 32 × 64, block x ∈ [8, 12), y ∈ [20, 24) → network (2 + 4, 5).
  cv::Mat tall(64, 32, CV_8UC3, cv::Scalar::all(0));
  tall(cv::Rect(8, 20, 4, 4)).setTo(cv::Scalar(0, 0, 255));
  const auto tall_detections = detector.detect(tall, PixelFormat::kBgr8);
  ASSERT_EQ(tall_detections.size(), 1U);
  // Centre (6.5, 5.5): network box (4.5, 4.5)–(8.5, 6.5) → x (4.5 − 4)·4 = 2 .. 18, y 18 .. 26.
  expectBox(tall_detections[0], 2.0, 18.0, 18.0, 26.0);
}

TEST_F(YoloDetectorTest, ResizeModeStretchesEachAxis)
{
  YoloDetectorConfig config = tinyConfig();
  config.resize_mode = ResizeMode::kStretch;
  YoloDetector detector(config);
  // 64 × 32 into 16 × 16: x / 4, y / 2. Block x ∈ [20, 24), y ∈ [8, 10) → network pixel (5, 4).
  cv::Mat image(32, 64, CV_8UC3, cv::Scalar::all(0));
  image(cv::Rect(20, 8, 4, 2)).setTo(cv::Scalar(0, 0, 255));
  const auto detections = detector.detect(image, PixelFormat::kBgr8);
  ASSERT_EQ(detections.size(), 1U);
  // Network box (3.5, 3.5)–(7.5, 5.5) → image x · 4, y · 2.
  expectBox(detections[0], 14.0, 7.0, 30.0, 11.0);
}

TEST_F(YoloDetectorTest, BoxesAreClippedToTheImage)
{
  YoloDetector detector(tinyConfig());
  // Cell (0, 0): box (−1.5, −0.5)–(2.5, 1.5) clipped to (0, 0)–(2.5, 1.5).
  const auto detections = detector.detect(imageWithPixel({16, 16}, 0, 0, {0, 0, 255}), PixelFormat::kBgr8);
  ASSERT_EQ(detections.size(), 1U);
  expectBox(detections[0], 0.0, 0.0, 2.5, 1.5);
}

TEST_F(YoloDetectorTest, InputSizeOverridesTheCfg)
{
  YoloDetectorConfig config = tinyConfig();
  config.input_width = 32;
  config.input_height = 32;
  YoloDetector detector(config);
  EXPECT_EQ(detector.inputSize(), cv::Size(32, 32));
  const auto detections = detector.detect(imageWithPixel({32, 32}, 20, 10, {0, 0, 255}), PixelFormat::kBgr8);
  ASSERT_EQ(detections.size(), 1U);
  // Anchors stay in network pixels: 4 × 2 around (20.5, 10.5).
  expectBox(detections[0], 18.5, 9.5, 22.5, 11.5);
}

TEST_F(YoloDetectorTest, ClassMapFiltersAndRenames)
{
  YoloDetectorConfig config = tinyConfig();
  config.class_map = {{"car", "car"}, {"truck", "lorry"}};
  YoloDetector detector(config);
  const auto detections =
      detector.detect(imageWithPixel({16, 16}, 5, 7, {255, 255, 255}), PixelFormat::kBgr8);
  ASSERT_EQ(detections.size(), 2U) << "person is not in the map and must be dropped";
  std::vector<std::string> labels{detections[0].label, detections[1].label};
  std::sort(labels.begin(), labels.end());
  EXPECT_EQ(labels, (std::vector<std::string>{"car", "lorry"}));
  for (const Detection& d : detections)
  {
    EXPECT_EQ(d.class_id, d.label == "car" ? 0U : 2U) << "class_id stays the model's class index";
  }
}

TEST_F(YoloDetectorTest, UnavailableBackendFallsBackToCpuWithAWarning)
{
  if (!cv::dnn::getAvailableTargets(cv::dnn::DNN_BACKEND_CUDA).empty())
  {
    GTEST_SKIP() << "this OpenCV has CUDA: no fallback to observe";
  }
  YoloDetectorConfig config = tinyConfig();
  config.backend = "cuda";
  config.target = "cuda_fp16";
  YoloDetector detector(config);
  ASSERT_EQ(detector.warnings().size(), 1U);
  EXPECT_NE(detector.warnings()[0].find("cuda/cuda_fp16"), std::string::npos) << detector.warnings()[0];
  EXPECT_EQ(detector.backendDescription(), "opencv/cpu");
  EXPECT_EQ(detector.detect(imageWithPixel({16, 16}, 5, 7, {0, 0, 255}), PixelFormat::kBgr8).size(), 1U);
}

/// Runs `construct` and expects a YoloModelError whose message contains every fragment.
template <typename F>
void expectModelError(F construct, const std::vector<std::string>& fragments)
{
  try
  {
    construct();
    ADD_FAILURE() << "no YoloModelError";
  }
  catch (const YoloModelError& e)
  {
    for (const std::string& fragment : fragments)
    {
      EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos) << e.what() << " lacks " << fragment;
    }
  }
}

TEST_F(YoloDetectorTest, TruncatedWeightsAreNamedInTheError)
{
  const YoloDetectorConfig config = tinyConfig();
  const auto full = std::filesystem::file_size(config.weights_path);
  // 3 × (5 + 3) = 24 filters: 24 biases + 24 × 3 weights = 96 floats after a 20-byte header.
  EXPECT_EQ(full, 20U + 4U * 96U);
  std::filesystem::resize_file(config.weights_path, full - 4);
  expectModelError([&] { YoloDetector detector(config); }, {config.weights_path, "truncated", "400", "404"});
  std::filesystem::resize_file(config.weights_path, 10);
  expectModelError([&] { YoloDetector detector(config); }, {config.weights_path, "truncated"});
  std::filesystem::resize_file(config.weights_path, full + 8);
  expectModelError([&] { YoloDetector detector(config); }, {config.weights_path, "too long"});
}

TEST_F(YoloDetectorTest, MissingFilesAreNamedInTheError)
{
  YoloDetectorConfig config = tinyConfig();
  YoloDetectorConfig no_cfg = config;
  no_cfg.model_path = directory_ + "/absent.cfg";
  expectModelError([&] { YoloDetector detector(no_cfg); }, {no_cfg.model_path, "cannot open"});
  YoloDetectorConfig no_weights = config;
  no_weights.weights_path = directory_ + "/absent.weights";
  expectModelError([&] { YoloDetector detector(no_weights); }, {no_weights.weights_path, "cannot open"});
  YoloDetectorConfig no_names = config;
  no_names.class_names_path = directory_ + "/absent.names";
  expectModelError([&] { YoloDetector detector(no_names); }, {no_names.class_names_path, "cannot open"});
  YoloDetectorConfig no_onnx = config;
  no_onnx.model_path = directory_ + "/absent.onnx";
  no_onnx.weights_path.clear();
  no_onnx.input_width = no_onnx.input_height = 416;
  expectModelError([&] { YoloDetector detector(no_onnx); }, {no_onnx.model_path, "cannot open"});
}

TEST_F(YoloDetectorTest, MismatchedAndCorruptFilesAreNamedInTheError)
{
  const YoloDetectorConfig config = tinyConfig();
  {
    std::ofstream names(config.class_names_path, std::ios::app);
    names << "bus\n";
  }
  expectModelError([&] { YoloDetector detector(config); },
                   {config.class_names_path, "4 classes", "classes=3"});

  const YoloDetectorConfig fresh = tinyConfig();
  {
    std::ofstream cfg(fresh.model_path, std::ios::app);
    cfg << "\n[lstm]\noutput=4\n";
  }
  expectModelError([&] { YoloDetector detector(fresh); }, {fresh.model_path + ":", "[lstm]", "unsupported"});

  std::ofstream not_a_cfg(directory_ + "/text.cfg");
  not_a_cfg << "hello world\n";
  not_a_cfg.close();
  YoloDetectorConfig garbage = tinyConfig();
  garbage.model_path = directory_ + "/text.cfg";
  expectModelError([&] { YoloDetector detector(garbage); }, {garbage.model_path});

  YoloDetectorConfig garbage_onnx = tinyConfig();
  garbage_onnx.model_path = directory_ + "/garbage.onnx";
  garbage_onnx.weights_path.clear();
  garbage_onnx.input_width = garbage_onnx.input_height = 32;
  std::ofstream(garbage_onnx.model_path) << "not a protobuf";
  expectModelError([&] { YoloDetector detector(garbage_onnx); }, {garbage_onnx.model_path});
}

TEST(YoloDetectorConfigTest, ValidateNamesTheField)
{
  YoloDetectorConfig good;
  good.model_path = "m.cfg";
  good.weights_path = "m.weights";
  good.class_names_path = "m.names";
  EXPECT_NO_THROW(good.validate());
  auto expectInvalid = [&](const std::function<void(YoloDetectorConfig&)>& change, const std::string& field)
  {
    YoloDetectorConfig bad = good;
    change(bad);
    try
    {
      bad.validate();
      ADD_FAILURE() << "accepted a bad " << field;
    }
    catch (const std::invalid_argument& e)
    {
      EXPECT_NE(std::string(e.what()).find(field), std::string::npos) << e.what();
    }
  };
  // The messages name the parameters as a launch file or YAML file sets them.
  expectInvalid([](YoloDetectorConfig& c) { c.model_path = "m.txt"; }, "model must");
  expectInvalid([](YoloDetectorConfig& c) { c.weights_path.clear(); }, "weights must");
  expectInvalid([](YoloDetectorConfig& c) { c.class_names_path.clear(); }, "class_names must");
  expectInvalid([](YoloDetectorConfig& c) { c.input_width = 416; }, "input_width");
  expectInvalid([](YoloDetectorConfig& c) { c.input_width = c.input_height = -32; }, "input_width");
  expectInvalid([](YoloDetectorConfig& c) { c.score_threshold = std::nan(""); }, "score_threshold");
  expectInvalid([](YoloDetectorConfig& c) { c.nms_threshold = 1.2; }, "nms_threshold");
  expectInvalid([](YoloDetectorConfig& c) { c.backend = "tensorrt"; }, "backend");
  expectInvalid([](YoloDetectorConfig& c) { c.target = "tpu"; }, "target");
  expectInvalid([](YoloDetectorConfig& c) { c.class_map = {{"car", ""}}; }, "class_map");
  // An ONNX model without a size is valid: it takes the one its file declares (test_onnx_input.cpp).
  YoloDetectorConfig onnx = good;
  onnx.model_path = "m.onnx";
  onnx.weights_path.clear();
  onnx.input_width = onnx.input_height = 0;
  EXPECT_NO_THROW(onnx.validate());
  EXPECT_EQ(resizeModeFromString("letterbox"), ResizeMode::kLetterbox);
  EXPECT_EQ(resizeModeFromString(toString(ResizeMode::kStretch)), ResizeMode::kStretch);
  EXPECT_THROW(resizeModeFromString("crop"), std::invalid_argument);
}

TEST(DarknetCfgTest, ParameterCountsOfTheRealArchitectures)
{
  // The official yolov3.weights is 248 007 048 bytes = 20 + 4 · 62 001 757, yolov3-tiny.weights
  // 35 434 956 bytes = 20 + 4 · 8 858 734.
  const DarknetCfgInfo yolov3 = parseDarknetCfg(kModelDir + "/yolov3.cfg");
  EXPECT_EQ(yolov3.parameters, 62001757U);
  EXPECT_EQ(yolov3.num_classes, 80);
  EXPECT_EQ(yolov3.yolo_layers, 3);
  EXPECT_EQ(yolov3.input_width, 608);
  EXPECT_EQ(yolov3.input_height, 608);
  const DarknetCfgInfo tiny = parseDarknetCfg(kModelDir + "/yolov3-tiny.cfg");
  EXPECT_EQ(tiny.parameters, 8858734U);
  EXPECT_EQ(tiny.yolo_layers, 2);
  EXPECT_EQ(tiny.input_width, 416);
  EXPECT_EQ(readClassNames(kModelDir + "/coco.names").size(), 80U);
}

TEST(DarknetCfgTest, Yolov4TinyStyleGroupedRouteIsCounted)
{
  // A grouped route (YOLOv4-tiny's CSP split) halves the channels: the 1×1 convolution after it
  // sees 8 of the 16 channels: 4 biases + 4 × 8 weights; the first: 16 + 3 BN × 16 + 16 × 3 × 9.
  const std::string dir = test::makeTempDirectory();
  const std::string path = dir + "/v4tiny.cfg";
  std::ofstream(path)
      << "[net]\nwidth=32\nheight=32\nchannels=3\n"
         "[convolutional]\nbatch_normalize=1\nfilters=16\nsize=3\nstride=2\npad=1\nactivation=mish\n"
         "[route]\nlayers=-1\ngroups=2\ngroup_id=1\n"
         "[convolutional]\nfilters=4\nsize=1\nstride=1\npad=1\nactivation=linear\n"
         "[route]\nlayers = -1, -3\n"
         "[maxpool]\nsize=2\nstride=2\n"
         "[yolo]\nmask=0\nanchors=1,1\nclasses=7\nnum=1\n";
  const DarknetCfgInfo info = parseDarknetCfg(path);
  EXPECT_EQ(info.parameters, 16U + 48U + 16U * 3U * 9U + 4U + 4U * 8U);
  EXPECT_EQ(info.num_classes, 7);
  std::ofstream(path) << "[net]\nwidth=32\nheight=32\n[route]\nlayers=-3\n";
  EXPECT_THROW(parseDarknetCfg(path), YoloModelError);
  std::filesystem::remove_all(dir);
}

TEST(InputTransformTest, LetterboxOfAKittiImage)
{
  // 1242 × 375 into 416 × 416: scale 416/1242, height 375 · 0.33494 = 125.6 → 126, pad (416 − 126)/2 = 145.
  const InputTransform t = InputTransform::make({1242, 375}, {416, 416}, ResizeMode::kLetterbox);
  EXPECT_EQ(t.resized_width, 416);
  EXPECT_EQ(t.resized_height, 126);
  EXPECT_DOUBLE_EQ(t.pad_x, 0.0);
  EXPECT_DOUBLE_EQ(t.pad_y, 145.0);
  // Network point (208, 208) is the image point (621, (208 − 145) · 375 / 126).
  const BoundingBox b = t.toImage(208, 208, 416, 271);
  EXPECT_NEAR(b.x_min, 621.0, 1e-3);
  EXPECT_NEAR(b.y_min, 63.0 * 375.0 / 126.0, 1e-3);
  EXPECT_NEAR(b.x_max, 1242.0, 1e-3);
  EXPECT_NEAR(b.y_max, 375.0, 1e-3);
  // Everything in the grey border clips onto the image edge.
  const BoundingBox border = t.toImage(-10, 0, 500, 100);
  EXPECT_FLOAT_EQ(border.x_min, 0.F);
  EXPECT_FLOAT_EQ(border.y_min, 0.F);
  EXPECT_FLOAT_EQ(border.x_max, 1242.F);
  EXPECT_FLOAT_EQ(border.y_max, 0.F);
  EXPECT_THROW(InputTransform::make({0, 10}, {416, 416}, ResizeMode::kLetterbox), std::invalid_argument);
}

TEST(DecodeTest, PixelLayoutMultipliesObjectnessAndSkipsBadRows)
{
  // Two classes; rows [cx, cy, w, h, objectness, p0, p1] in network pixels (an ONNX export).
  cv::Mat rows = (cv::Mat_<float>(3, 7) << 50, 40, 20, 10, 0.5F, 0.2F, 0.9F,  //
                  10, 10, 4, 4, 0.F, 1.F, 1.F,                                // objectness 0
                  std::nanf(""), 10, 4, 4, 1.F, 1.F, 1.F);                    // NaN box
  const std::vector<int> shape{1, 3, 7};
  const cv::Mat blob = rows.reshape(1, shape);
  const auto candidates = decodeYoloOutputs({blob}, YoloOutputLayout::kPixels, {416, 416}, 2, 0.3);
  ASSERT_EQ(candidates.size(), 1U);
  EXPECT_EQ(candidates[0].class_id, 1);
  EXPECT_FLOAT_EQ(candidates[0].score, 0.45F);
  EXPECT_DOUBLE_EQ(candidates[0].box.x, 40.0);
  EXPECT_DOUBLE_EQ(candidates[0].box.y, 35.0);
  EXPECT_DOUBLE_EQ(candidates[0].box.width, 20.0);
  EXPECT_DOUBLE_EQ(candidates[0].box.height, 10.0);
  // The same row read as OpenCV's region layout: normalised box, class column is the score.
  const auto region =
      decodeYoloOutputs({rows.row(0).clone()}, YoloOutputLayout::kOpenCvRegion, {100, 200}, 2, 0.3);
  ASSERT_EQ(region.size(), 1U);
  EXPECT_FLOAT_EQ(region[0].score, 0.9F);
  EXPECT_DOUBLE_EQ(region[0].box.x, 50 * 100 - 20 * 100 / 2.0);
  EXPECT_THROW(decodeYoloOutputs({rows}, YoloOutputLayout::kPixels, {416, 416}, 3, 0.3),
               std::invalid_argument);
}

TEST(DecodeTest, SuppressionIsPerClass)
{
  // Class 0: two boxes with IoU 0.6 (the weaker goes) and a disjoint one; class 1: a box equal
  // to the strongest class-0 box (stays).
  const std::vector<YoloCandidate> candidates{
      {0, 0.9F, {0, 0, 4, 2}}, {0, 0.8F, {1, 0, 4, 2}}, {0, 0.7F, {10, 10, 4, 2}}, {1, 0.5F, {0, 0, 4, 2}}};
  const auto kept = suppressPerClass(candidates, 0.3, 0.45);
  ASSERT_EQ(kept.size(), 3U);
  EXPECT_FLOAT_EQ(kept[0].score, 0.9F);
  EXPECT_FLOAT_EQ(kept[1].score, 0.7F);
  EXPECT_EQ(kept[2].class_id, 1);
}

TEST(DrawTest, BoxesAreDrawnInTheImage)
{
  cv::Mat image(40, 60, CV_8UC3, cv::Scalar::all(0));
  Detection d;
  d.class_id = 2;
  d.label = "car";
  d.score = 0.5F;
  d.box = {10.F, 20.F, 50.F, 35.F};
  drawDetections(image, {d});
  EXPECT_EQ(image.at<cv::Vec3b>(35, 30), cv::Vec3b(0, 255, 0)) << "bottom edge in the class-2 colour";
  EXPECT_EQ(image.at<cv::Vec3b>(28, 30), cv::Vec3b(0, 0, 0)) << "inside stays untouched";
}

}  // namespace
}  // namespace grid_vision_fusion

namespace grid_vision_fusion
{
namespace
{
TEST(Yolov4StyleTest, MishGroupedRouteAndScaleXYLoadAndRun)
{
  // The YOLOv4(-tiny) building blocks: mish activation, CSP split by a grouped route,
  // concatenating route, scale_x_y in [yolo]. Random weights of the exact size the cfg needs.
  const std::string dir = test::makeTempDirectory();
  const std::string cfg = dir + "/v4.cfg";
  std::ofstream(cfg)
      << "[net]\nwidth=32\nheight=32\nchannels=3\n"
         "[convolutional]\nbatch_normalize=1\nfilters=8\nsize=3\nstride=2\npad=1\nactivation=mish\n"
         "[route]\nlayers=-1\ngroups=2\ngroup_id=1\n"
         "[convolutional]\nbatch_normalize=1\nfilters=4\nsize=3\nstride=1\npad=1\nactivation=leaky\n"
         "[route]\nlayers=-1,-3\n"
         "[maxpool]\nsize=2\nstride=2\n"
         "[convolutional]\nfilters=12\nsize=1\nstride=1\npad=1\nactivation=linear\n"
         "[yolo]\nmask=0\nanchors=10,14\nclasses=7\nnum=1\nscale_x_y=1.05\n";
  std::ofstream names(dir + "/v4.names");
  for (int c = 0; c < 7; ++c)
  {
    names << "c" << c << "\n";
  }
  names.close();
  const DarknetCfgInfo info = parseDarknetCfg(cfg);
  ASSERT_EQ(info.blocks.size(), 3U);
  EXPECT_EQ(info.blocks[1].weights, 4U * 4U * 9U) << "the grouped route passes 4 of 8 channels";
  EXPECT_EQ(info.blocks[2].weights, 12U * 12U) << "the concatenating route gives 4 + 8 channels";
  std::ofstream weights(dir + "/v4.weights", std::ios::binary);
  const std::int32_t version[3] = {0, 2, 0};
  const std::uint64_t seen = 0;
  weights.write(reinterpret_cast<const char*>(version), sizeof(version));
  weights.write(reinterpret_cast<const char*>(&seen), sizeof(seen));
  for (std::size_t i = 0; i < info.parameters; ++i)
  {
    const float value = 0.5F + 0.01F * static_cast<float>(i % 7);  // positive: valid BN variances
    weights.write(reinterpret_cast<const char*>(&value), sizeof(value));
  }
  weights.close();
  YoloDetectorConfig config;
  config.model_path = cfg;
  config.weights_path = dir + "/v4.weights";
  config.class_names_path = dir + "/v4.names";
  config.score_threshold = 0.0;
  YoloDetector detector(config);
  EXPECT_EQ(detector.inputSize(), cv::Size(32, 32));
  cv::Mat image(48, 64, CV_8UC3, cv::Scalar(10, 200, 90));
  const auto detections = detector.detect(image, PixelFormat::kBgr8);
  for (const Detection& d : detections)
  {
    EXPECT_GE(d.box.x_min, 0.F);
    EXPECT_LE(d.box.x_max, 64.F);
    EXPECT_GE(d.box.y_min, 0.F);
    EXPECT_LE(d.box.y_max, 48.F);
    EXPECT_LT(d.class_id, 7U);
  }
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace grid_vision_fusion

namespace grid_vision_fusion
{
namespace
{
Detection box(const std::string& label, float score, float x_min, float y_min, float x_max, float y_max)
{
  Detection d;
  d.label = label;
  d.score = score;
  d.box = {x_min, y_min, x_max, y_max};
  return d;
}

TEST(MergeRiders, APersonOverABicycleIsOneBox)
{
  // A rider (x 100-140, y 40-150) on a bicycle (x 90-160, y 100-170); a pedestrian beside it.
  const RiderMergeResult result =
      mergeRiders({box("bicycle", 0.6F, 90, 100, 160, 170), box("person", 0.8F, 100, 40, 140, 150),
                   box("person", 0.9F, 300, 40, 340, 170)},
                  "person", {{"bicycle", "cyclist"}});
  ASSERT_EQ(result.riders.size(), 1U);
  EXPECT_EQ(result.riders[0].label, "cyclist");
  EXPECT_FLOAT_EQ(result.riders[0].score, 0.8F);
  EXPECT_FLOAT_EQ(result.riders[0].box.x_min, 90.F);
  EXPECT_FLOAT_EQ(result.riders[0].box.y_min, 40.F);
  EXPECT_FLOAT_EQ(result.riders[0].box.x_max, 160.F);
  EXPECT_FLOAT_EQ(result.riders[0].box.y_max, 170.F);
  ASSERT_EQ(result.others.size(), 1U);
  EXPECT_FLOAT_EQ(result.others[0].box.x_min, 300.F) << "the pedestrian beside it stays a person";
}

TEST(MergeRiders, OnlyAPersonOverTheVehicleRidesIt)
{
  const Detection bicycle = box("bicycle", 0.6F, 90, 100, 160, 170);
  // Beside it (centre outside), standing below its top only by a sliver, or wholly above it.
  for (const Detection& person :
       {box("person", 0.8F, 150, 40, 190, 170), box("person", 0.8F, 100, 40, 140, 110),
        box("person", 0.8F, 100, 10, 140, 90)})
  {
    const RiderMergeResult result = mergeRiders({bicycle, person}, "person", {{"bicycle", "cyclist"}});
    EXPECT_TRUE(result.riders.empty()) << person.box.x_min << " " << person.box.y_max;
    EXPECT_EQ(result.others.size(), 2U);
  }
  // Two bicycles, one rider: the higher-scored bicycle gets it, the other stays a bicycle.
  const RiderMergeResult two =
      mergeRiders({bicycle, box("bicycle", 0.7F, 95, 105, 150, 170), box("person", 0.8F, 100, 40, 140, 150)},
                  "person", {{"bicycle", "cyclist"}});
  ASSERT_EQ(two.riders.size(), 1U);
  EXPECT_FLOAT_EQ(two.riders[0].box.x_max, 150.F);
  ASSERT_EQ(two.others.size(), 1U);
  EXPECT_EQ(two.others[0].label, "bicycle");
}

TEST(PublishedDetections, ClassMapAppliesToTheBoxesNotMerged)
{
  YoloDetectorConfig config;
  config.class_map = {{"person", "pedestrian"}, {"car", "car"}};
  config.rider_merge = {{"bicycle", "cyclist"}, {"motorbike", "cyclist"}};
  const std::vector<Detection> published =
      publishedDetections({box("motorbike", 0.5F, 90, 100, 160, 170), box("person", 0.7F, 100, 40, 140, 150),
                           box("bicycle", 0.9F, 400, 100, 460, 170), box("car", 0.6F, 500, 80, 600, 170),
                           box("person", 0.4F, 300, 40, 340, 170)},
                          config);
  std::vector<std::string> labels;
  for (const Detection& d : published)
  {
    labels.push_back(d.label);
  }
  // The parked bicycle has no rider and no class_map entry: dropped; by decreasing score.
  EXPECT_EQ(labels, (std::vector<std::string>{"cyclist", "car", "pedestrian"}));
  config.rider_merge.clear();
  EXPECT_EQ(publishedDetections({box("bicycle", 0.9F, 400, 100, 460, 170)}, config).size(), 0U);
  config.class_map.clear();
  EXPECT_EQ(publishedDetections({box("bicycle", 0.9F, 400, 100, 460, 170)}, config).at(0).label, "bicycle");
}

TEST(PublishedDetections, RiderMergeIsValidated)
{
  YoloDetectorConfig config;
  config.model_path = "m.cfg";
  config.weights_path = "m.weights";
  config.class_names_path = "m.names";
  config.rider_merge = {{"person", "cyclist"}};
  EXPECT_THROW(config.validate(), std::invalid_argument);
  config.rider_merge = {{"bicycle", ""}};
  EXPECT_THROW(config.validate(), std::invalid_argument);
  config.rider_merge = {{"bicycle", "cyclist"}};
  EXPECT_NO_THROW(config.validate());
  config.rider_class.clear();
  EXPECT_THROW(config.validate(), std::invalid_argument);
}

}  // namespace
}  // namespace grid_vision_fusion
