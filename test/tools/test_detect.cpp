// The detect tool: on the tiny Darknet model (test/detection/tiny_darknet.h) over a folder of two
// images it writes two KITTI result files that the replay backend, configured by the package's
// config/yolo_detector.yaml as the nodelet is, reads back with the boxes, scores and labels the
// detector gives; KITTI raw drive folders; unreadable images; usage errors (exit 2) and a missing
// model (exit 1, naming the file).
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <opencv2/imgcodecs.hpp>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <string>
#include <vector>

#include "../detection/tiny_darknet.h"
#include "grid_vision_fusion/detection/detection_replay.h"
#include "grid_vision_fusion/detection/yolo_detector.h"
#include "grid_vision_fusion/ros/node_params.h"

namespace grid_vision_fusion
{
namespace
{
namespace fs = std::filesystem;

const std::string kConfig = std::string(GVF_SOURCE_DIR) + "/config/yolo_detector.yaml";

struct Result
{
  int status = -1;     ///< exit status
  std::string output;  ///< stdout and stderr
};

Result run(const std::string& arguments)
{
  Result result;
  std::unique_ptr<FILE, int (*)(FILE*)> pipe(
      popen((std::string(DETECT) + " " + arguments + " 2>&1").c_str(), "r"), pclose);
  char buffer[512];
  while (pipe && std::fgets(buffer, sizeof(buffer), pipe.get()))
  {
    result.output += buffer;
  }
  const int status = pclose(pipe.release());
  result.status = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return result;
}

/// A black 16 × 16 image (the tiny model's input size: one YOLO cell per pixel) with pure colour
/// pixels: red fires the model's "car", green its "person", blue its "truck".
cv::Mat imageWith(const std::vector<std::pair<cv::Point, cv::Vec3b>>& pixels)
{
  cv::Mat image(16, 16, CV_8UC3, cv::Scalar::all(0));
  for (const auto& [where, bgr] : pixels)
  {
    image.at<cv::Vec3b>(where) = bgr;
  }
  return image;
}

const cv::Vec3b kRed(0, 0, 255), kGreen(0, 255, 0), kBlue(255, 0, 0);

class DetectTool : public ::testing::Test
{
protected:
  void SetUp() override
  {
    dir_ = test::makeTempDirectory();
    fs::create_directories(dir_ + "/model");
    model_ = test::writeTinyDarknet(dir_ + "/model", test::TinyDarknetSpec());
  }
  void TearDown() override { fs::remove_all(dir_); }

  std::string modelArgs() const
  {
    return "--model " + model_.cfg + " --weights " + model_.weights + " --class-names " + model_.names +
           " --config " + kConfig + " --input 16x16";
  }

  /// The detector configured as the tool configures it: the package's config with the model
  /// files, the input size and the tool's default score threshold.
  DetectorParams params(const std::string& backend, const std::string& replay_directory) const
  {
    YamlParamSource source = YamlParamSource::fromFile(kConfig);
    source.set("backend", backend);
    source.set("model", model_.cfg);
    source.set("weights", model_.weights);
    source.set("class_names", model_.names);
    source.set("input_width", 16);
    source.set("input_height", 16);
    source.set("score_threshold", 0.25);
    source.set("replay/directory", replay_directory);
    return DetectorParams::fromParams(source);
  }

  std::string dir_;
  test::TinyDarknetFiles model_;
};

TEST_F(DetectTool, WritesLabelFilesThatTheReplayReadsBackUnchanged)
{
  const fs::path images = fs::path(dir_) / "images";
  fs::create_directories(images);
  const std::vector<cv::Mat> frames{imageWith({{{4, 4}, kRed}, {{10, 12}, kGreen}}),
                                    imageWith({{{3, 10}, kBlue}, {{12, 3}, kRed}, {{12, 12}, kRed}})};
  for (std::size_t i = 0; i < frames.size(); ++i)
  {
    ASSERT_TRUE(cv::imwrite((images / ("00000" + std::to_string(i) + ".png")).string(), frames[i]));
  }
  std::ofstream(images / "notes.txt") << "not an image: ignored\n";
  const fs::path output = fs::path(dir_) / "labels";
  const Result result = run(modelArgs() + " --output " + output.string() + " --overlay " + images.string());
  ASSERT_EQ(result.status, 0) << result.output;
  EXPECT_NE(result.output.find("2 of 2 images, 5 detections"), std::string::npos) << result.output;
  EXPECT_NE(result.output.find("Car 3 Pedestrian 1 Truck 1"), std::string::npos) << result.output;
  EXPECT_NE(result.output.find("--replay-file-pattern %06d.txt"), std::string::npos) << result.output;
  EXPECT_TRUE(fs::exists(output / "overlay" / "000000.png"));
  EXPECT_TRUE(fs::exists(output / "overlay" / "000001.png"));
  std::size_t files = 0;
  for (const auto& entry : fs::directory_iterator(output))
  {
    files += entry.is_regular_file() ? 1 : 0;
  }
  EXPECT_EQ(files, 2U) << "one label file per image, nothing else";

  YoloDetector detector(params("opencv_dnn", "").yolo);
  DetectionReplayConfig replay_config = params("replay", output.string()).replay;
  replay_config.score_threshold = 0.0;  // everything written comes back
  DetectionReplay replay(replay_config);
  for (std::size_t i = 0; i < frames.size(); ++i)
  {
    SCOPED_TRACE("frame " + std::to_string(i));
    const std::vector<Detection> expected = detector.detect(frames[i], PixelFormat::kBgr8);
    const std::vector<Detection> replayed = replay.detectionsOf(static_cast<std::int64_t>(i), 16, 16);
    ASSERT_EQ(replayed.size(), expected.size());
    ASSERT_EQ(expected.size(), i == 0 ? 2U : 3U);
    for (std::size_t k = 0; k < expected.size(); ++k)
    {
      EXPECT_EQ(replayed[k].label, expected[k].label);
      EXPECT_EQ(replayed[k].score, expected[k].score);
      EXPECT_EQ(replayed[k].box.x_min, expected[k].box.x_min);
      EXPECT_EQ(replayed[k].box.y_min, expected[k].box.y_min);
      EXPECT_EQ(replayed[k].box.x_max, expected[k].box.x_max);
      EXPECT_EQ(replayed[k].box.y_max, expected[k].box.y_max);
    }
  }
  // The tiny model's "person" is written as KITTI's Pedestrian (class_map person: pedestrian).
  std::ifstream first(output / "000000.txt");
  std::string text((std::istreambuf_iterator<char>(first)), std::istreambuf_iterator<char>());
  EXPECT_NE(text.find("Pedestrian -1 -1 -10 "), std::string::npos) << text;
  EXPECT_NE(text.find(" -1 -1 -1 -1000 -1000 -1000 -10 "), std::string::npos) << text;
}

TEST_F(DetectTool, TakesTheImagesOfAKittiRawDrive)
{
  const fs::path drive = fs::path(dir_) / "2011_09_26_drive_0001_sync";
  fs::create_directories(drive / "image_02" / "data");
  ASSERT_TRUE(
      cv::imwrite((drive / "image_02" / "data" / "0000000000.png").string(), imageWith({{{4, 4}, kRed}})));
  ASSERT_TRUE(cv::imwrite((drive / "image_02" / "data" / "0000000001.png").string(), imageWith({})));
  const fs::path output = fs::path(dir_) / "labels";
  const Result result = run(modelArgs() + " --quiet --output " + output.string() + " " + drive.string());
  ASSERT_EQ(result.status, 0) << result.output;
  EXPECT_EQ(readKittiLabels((output / "0000000000.txt").string()).size(), 1U);
  EXPECT_EQ(readKittiLabels((output / "0000000001.txt").string()).size(), 0U) << "an empty file: no object";
  EXPECT_NE(result.output.find("--replay-file-pattern %010d.txt"), std::string::npos) << result.output;
}

TEST_F(DetectTool, SkipsAnUnreadableImageAndExitsOneNamingIt)
{
  const fs::path images = fs::path(dir_) / "images";
  fs::create_directories(images);
  ASSERT_TRUE(cv::imwrite((images / "000000.png").string(), imageWith({{{4, 4}, kRed}})));
  std::ofstream(images / "000001.png") << "not a PNG";
  ASSERT_TRUE(cv::imwrite((images / "000002.png").string(), imageWith({{{4, 4}, kBlue}})));
  const fs::path output = fs::path(dir_) / "labels";
  const Result result = run(modelArgs() + " --output " + output.string() + " " + images.string());
  EXPECT_EQ(result.status, 1) << result.output;
  EXPECT_NE(result.output.find((images / "000001.png").string() + ": cannot read the image"),
            std::string::npos)
      << result.output;
  EXPECT_NE(result.output.find("1 image(s) could not be read"), std::string::npos) << result.output;
  EXPECT_TRUE(fs::exists(output / "000000.txt"));
  EXPECT_FALSE(fs::exists(output / "000001.txt"));
  EXPECT_TRUE(fs::exists(output / "000002.txt")) << "the images after it are done";
}

TEST_F(DetectTool, BadArgumentsExitTwoWithTheUsage)
{
  const std::string image = dir_ + "/000000.png";
  ASSERT_TRUE(cv::imwrite(image, imageWith({})));
  const std::string output = " --output " + dir_ + "/labels ";
  for (const std::string& arguments :
       {modelArgs() + output + image + " --bogus", modelArgs() + " " + image, modelArgs() + output,
        "--output " + dir_ + "/labels " + image, modelArgs() + output + image + " --input 640",
        modelArgs() + output + image + " --score-threshold 1.5",
        modelArgs() + output + image + " --class-map car",
        modelArgs() + output + image + " --all-classes --class-map car=Car",
        "--model " + model_.cfg + output + image, "--model m.onnx --weights m.weights" + output + image,
        "--model m.pt" + output + image, modelArgs() + output + image + " --nms"})
  {
    const Result result = run(arguments);
    EXPECT_EQ(result.status, 2) << arguments << "\n" << result.output;
    EXPECT_NE(result.output.find("usage: detect"), std::string::npos) << arguments << "\n" << result.output;
  }
  EXPECT_FALSE(fs::exists(dir_ + "/labels"));
  EXPECT_EQ(run("--help").status, 0);
  // The messages name the options as typed, not the detector's parameters (weights_path, ...).
  EXPECT_NE(
      run("--model " + model_.cfg + output + image).output.find("give its .weights file with --weights"),
      std::string::npos);
  EXPECT_NE(
      run("--model m.onnx --weights m.weights" + output + image).output.find("--weights m.weights is not"),
      std::string::npos);
}

TEST_F(DetectTool, TwoImagesOfOneNameAreAUsageError)
{
  for (const char* folder : {"a", "b"})
  {
    fs::create_directories(fs::path(dir_) / folder);
    ASSERT_TRUE(cv::imwrite((fs::path(dir_) / folder / "000000.png").string(), imageWith({})));
  }
  const Result result =
      run(modelArgs() + " --output " + dir_ + "/labels " + dir_ + "/a " + dir_ + "/b/000000.png");
  EXPECT_EQ(result.status, 2) << result.output;
  EXPECT_NE(result.output.find("000000.txt"), std::string::npos) << result.output;
}

TEST_F(DetectTool, AMissingModelOrInputExitsOneNamingTheFile)
{
  const std::string image = dir_ + "/000000.png";
  ASSERT_TRUE(cv::imwrite(image, imageWith({})));
  const std::string missing_weights = dir_ + "/model/missing.weights";
  Result result = run("--model " + model_.cfg + " --weights " + missing_weights + " --class-names " +
                      model_.names + " --config " + kConfig + " --output " + dir_ + "/labels " + image);
  EXPECT_EQ(result.status, 1) << result.output;
  EXPECT_NE(result.output.find(missing_weights), std::string::npos) << result.output;
  EXPECT_EQ(result.output.find("usage:"), std::string::npos) << result.output;

  const std::string missing_model = dir_ + "/model/missing.onnx";
  result = run("--model " + missing_model + " --class-names " + model_.names + " --config " + kConfig +
               " --output " + dir_ + "/labels " + image);
  EXPECT_EQ(result.status, 1) << result.output;
  EXPECT_NE(result.output.find(missing_model), std::string::npos) << result.output;

  const std::string missing_image = dir_ + "/no_such_image.png";
  result = run(modelArgs() + " --output " + dir_ + "/labels " + missing_image);
  EXPECT_EQ(result.status, 1) << result.output;
  EXPECT_NE(result.output.find(missing_image + ": no such file"), std::string::npos) << result.output;
  EXPECT_FALSE(fs::exists(dir_ + "/labels")) << "nothing written before the model and the inputs are checked";
}

}  // namespace
}  // namespace grid_vision_fusion
