// readOnnxInput()/parseOnnxInput() on ONNX protobufs encoded here field by field (onnx.proto's
// numbers), and YoloDetector taking the input size an ONNX file declares: a size given that the
// file contradicts is one error naming both, before OpenCV reads the graph.
#include <gtest/gtest.h>

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <initializer_list>
#include <string>

#include "grid_vision_fusion/detection/yolo_detector.h"
#include "tiny_darknet.h"  // test::makeTempDirectory

namespace grid_vision_fusion
{
namespace
{
namespace fs = std::filesystem;

std::string varint(std::uint64_t value)
{
  std::string out;
  do
  {
    const auto low = static_cast<char>(value & 0x7FU);
    value >>= 7U;
    out += static_cast<char>(low | (value != 0 ? 0x80 : 0));
  } while (value != 0);
  return out;
}

/// A length-delimited field.
std::string message(std::uint32_t number, const std::string& content)
{
  return varint(number << 3U | 2U) + varint(content.size()) + content;
}

/// A varint field.
std::string number(std::uint32_t field, std::uint64_t value)
{
  return varint(field << 3U) + varint(value);
}

/// A ValueInfoProto of a float tensor; a dimension < 0 is named ("batch") instead of valued.
std::string valueInfo(const std::string& name, std::initializer_list<long long> dims)
{
  std::string shape;
  for (const long long dim : dims)
  {
    shape += message(1, dim >= 0 ? number(1, static_cast<std::uint64_t>(dim)) : message(2, "batch"));
  }
  const std::string tensor_type = number(1, 1) + message(2, shape);  // elem_type FLOAT, shape
  return message(1, name) + message(2, message(1, tensor_type));
}

/// A ModelProto: ir_version, producer, then the graph (a node, an initializer, the inputs).
std::string model(const std::string& inputs, const std::string& initializers = "")
{
  const std::string node = message(1, message(1, "images") + message(2, "out")) + message(4, "Conv");
  const std::string graph = node + message(2, "g") + initializers + inputs;
  return number(1, 7) + message(2, "test") + message(7, graph);
}

TEST(OnnxInput, ReadsTheFirstGraphInputThatIsNotAWeight)
{
  const std::string initializer = message(5, number(1, 4) + message(8, "conv.weight"));
  const std::string bytes = model(message(11, valueInfo("conv.weight", {16, 3, 3, 3})) +
                                      message(11, valueInfo("images", {1, 3, 192, 640})),
                                  initializer);
  const OnnxInputInfo info = parseOnnxInput(bytes, "m.onnx");
  EXPECT_EQ(info.name, "images");
  EXPECT_EQ(info.shape, (std::vector<long long>{1, 3, 192, 640}));
  EXPECT_EQ(info.imageSize(), cv::Size(640, 192));
}

TEST(OnnxInput, OpenDimensionsAreMinusOne)
{
  const OnnxInputInfo info = parseOnnxInput(model(message(11, valueInfo("x", {-1, 3, -1, -1}))), "m.onnx");
  EXPECT_EQ(info.shape, (std::vector<long long>{-1, 3, -1, -1}));
  EXPECT_TRUE(info.imageSize().empty());
  EXPECT_TRUE(parseOnnxInput(model(message(11, valueInfo("x", {1, 640}))), "m.onnx").imageSize().empty());
}

TEST(OnnxInput, BadFilesNameTheFileAndWhatIsWrong)
{
  const auto error = [](const std::string& bytes) -> std::string
  {
    try
    {
      parseOnnxInput(bytes, "m.onnx");
    }
    catch (const YoloModelError& e)
    {
      return e.what();
    }
    return "no error";
  };
  EXPECT_EQ(error(""), "m.onnx: not an ONNX model (no graph)");
  EXPECT_EQ(error(model("")), "m.onnx: the ONNX graph declares no input");
  const std::string good = model(message(11, valueInfo("images", {1, 3, 192, 640})));
  EXPECT_NE(error(good.substr(0, good.size() - 3)).find("m.onnx: not a well-formed ONNX model (a field of"),
            std::string::npos);
  EXPECT_EQ(error(std::string("\x08\xff", 2)), "m.onnx: not a well-formed ONNX model (truncated varint)");
  EXPECT_EQ(error(std::string("\x0f", 1)),
            "m.onnx: not a well-formed ONNX model (unknown protobuf wire type 7)");
  EXPECT_EQ(error("<html>not found</html>").rfind("m.onnx: not", 0), 0U);
  try
  {
    readOnnxInput("/nonexistent/m.onnx");
    ADD_FAILURE() << "no error for a missing file";
  }
  catch (const YoloModelError& e)
  {
    EXPECT_STREQ(e.what(), "/nonexistent/m.onnx: cannot open the ONNX model file");
  }
}

class OnnxDetectorSize : public ::testing::Test
{
protected:
  void SetUp() override
  {
    dir_ = test::makeTempDirectory();
    config_.model_path = dir_ + "/yolo-640x192.onnx";
    std::ofstream(config_.model_path, std::ios::binary)
        << model(message(11, valueInfo("images", {1, 3, 192, 640})));
    config_.class_names_path = std::string(GVF_MODEL_DIR) + "/coco.names";
  }
  void TearDown() override { fs::remove_all(dir_); }

  std::string error()
  {
    try
    {
      YoloDetector detector(config_);
    }
    catch (const YoloModelError& e)
    {
      return e.what();
    }
    return "no error";
  }

  std::string dir_;
  YoloDetectorConfig config_;
};

TEST_F(OnnxDetectorSize, ASizeTheFileContradictsIsOneErrorNamingBoth)
{
  config_.input_width = 416;
  config_.input_height = 416;
  EXPECT_EQ(error(),
            config_.model_path +
                ": the model declares its input \"images\" [1, 3, 192, 640], an input of 640x192, but the "
                "input size given is 416x416: give 640x192 or no size at all");
}

TEST_F(OnnxDetectorSize, WithNoSizeGivenTheDeclaredOneIsTaken)
{
  // The declared size is accepted (no size error); OpenCV then refuses this graph of one Conv
  // without weights: the error is OpenCV's about the model, not about the size.
  const std::string what = error();
  EXPECT_EQ(what.find("input size"), std::string::npos) << what;
  EXPECT_NE(what.find("OpenCV cannot load the model"), std::string::npos) << what;
  config_.input_width = 640;
  config_.input_height = 192;
  EXPECT_EQ(error().find("input size"), std::string::npos);
}

TEST_F(OnnxDetectorSize, AnOpenSizeMustBeGiven)
{
  std::ofstream(config_.model_path, std::ios::binary)
      << model(message(11, valueInfo("images", {1, 3, -1, -1})));
  EXPECT_EQ(error(),
            config_.model_path +
                ": the model's input \"images\" [1, 3, ?, ?] leaves its image size open: give the input "
                "size it was exported for");
}

}  // namespace
}  // namespace grid_vision_fusion
