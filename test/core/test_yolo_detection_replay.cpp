// DetectionReplay: frame indices, file names, class mapping, scores, clipping, errors.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "grid_vision_fusion/core/detection_replay.h"

namespace grid_vision_fusion
{
namespace
{
const std::string kLabelDir = std::string(GVF_TEST_DATA_DIR) + "/kitti_labels";

DetectionReplayConfig groundTruthConfig()
{
  DetectionReplayConfig config;
  config.directory = kLabelDir + "/label_2";
  return config;
}

TEST(DetectionReplayTest, CounterWalksTheFramesFromFirstIndex)
{
  DetectionReplayConfig config = groundTruthConfig();
  config.first_index = 1;
  DetectionReplay replay(config);
  EXPECT_EQ(replay.nextFrameIndex(77), 1);
  EXPECT_EQ(replay.nextFrameIndex(3), 2);
  EXPECT_EQ(replay.pathOf(2), kLabelDir + "/label_2/000002.txt");
}

TEST(DetectionReplayTest, HeaderSeqPlusOffset)
{
  DetectionReplayConfig config = groundTruthConfig();
  config.index_source = FrameIndexSource::kHeaderSeq;
  config.first_index = -10;
  DetectionReplay replay(config);
  EXPECT_EQ(replay.nextFrameIndex(12), 2);
  EXPECT_EQ(replay.nextFrameIndex(12), 2);
  EXPECT_THROW(replay.nextFrameIndex(3), std::out_of_range);
}

TEST(DetectionReplayTest, GroundTruthWithTheDefaultNamesDropsDontCare)
{
  DetectionReplay replay(groundTruthConfig());
  // 000001: Truck, Car, Cyclist and four DontCare.
  const auto detections = replay.detectionsOf(1, 1242, 375);
  ASSERT_EQ(detections.size(), 3U);
  EXPECT_EQ(detections[0].label, "truck");
  EXPECT_EQ(detections[0].class_id, 2U);
  EXPECT_FLOAT_EQ(detections[0].score, 1.F);
  EXPECT_FLOAT_EQ(detections[0].box.x_min, 599.41F);
  EXPECT_FLOAT_EQ(detections[0].box.y_min, 156.40F);
  EXPECT_FLOAT_EQ(detections[0].box.x_max, 629.75F);
  EXPECT_FLOAT_EQ(detections[0].box.y_max, 189.25F);
  EXPECT_EQ(detections[1].label, "car");
  EXPECT_EQ(detections[1].class_id, 0U);
  EXPECT_EQ(detections[2].label, "cyclist");
  EXPECT_EQ(detections[2].class_id, 5U);
}

TEST(DetectionReplayTest, ClassMapScoresThresholdAndClipping)
{
  DetectionReplayConfig config;
  config.directory = kLabelDir + "/results";
  config.class_map = {{"Car", "car"}, {"Pedestrian", "pedestrian"}, {"Truck", "truck"}};
  config.score_threshold = 0.1;
  DetectionReplay replay(config);
  // 000007: Car 0.91, Pedestrian 0.42 (left −15 → 0), Truck 0.08 (below 0.1), Cyclist (not mapped).
  const auto detections = replay.detectionsOf(7, 1242, 375);
  ASSERT_EQ(detections.size(), 2U);
  EXPECT_EQ(detections[0].label, "car");
  EXPECT_FLOAT_EQ(detections[0].score, 0.91F);
  EXPECT_FLOAT_EQ(detections[0].box.y_max, 220.5F);
  EXPECT_EQ(detections[1].label, "pedestrian");
  EXPECT_EQ(detections[1].class_id, 3U);
  EXPECT_FLOAT_EQ(detections[1].score, 0.42F);
  EXPECT_FLOAT_EQ(detections[1].box.x_min, 0.F);
  replay.setScoreThreshold(0.0);
  const auto all = replay.detectionsOf(7, 1242, 375);
  ASSERT_EQ(all.size(), 3U);
  EXPECT_FLOAT_EQ(all[2].box.x_max, 1242.F) << "truck clipped to the image width";
  EXPECT_FLOAT_EQ(all[2].box.y_max, 375.F);
  EXPECT_THROW(replay.setScoreThreshold(2.0), std::invalid_argument);
}

TEST(DetectionReplayTest, MissingFileIsAnErrorOrEmpty)
{
  DetectionReplayConfig config = groundTruthConfig();
  DetectionReplay strict(config);
  EXPECT_THROW(strict.detectionsOf(5, 1242, 375), KittiLabelError);
  config.missing_file_is_empty = true;
  DetectionReplay lenient(config);
  EXPECT_TRUE(lenient.detectionsOf(5, 1242, 375).empty());
}

TEST(DetectionReplayTest, MalformedFileErrorNamesFileAndLine)
{
  const std::string dir = (std::filesystem::temp_directory_path() / "gvf_replay_test").string();
  std::filesystem::create_directories(dir);
  std::ofstream(dir + "/000003.txt") << "Car 0 0 0 1 2 3 4 1 1 1 0 0 0 0\nCar 0 0 0 1 2\n";
  DetectionReplayConfig config;
  config.directory = dir;
  DetectionReplay replay(config);
  try
  {
    replay.detectionsOf(3, 100, 100);
    ADD_FAILURE() << "no error";
  }
  catch (const KittiLabelError& e)
  {
    EXPECT_NE(std::string(e.what()).find(dir + "/000003.txt:2:"), std::string::npos) << e.what();
  }
  std::filesystem::remove_all(dir);
}

TEST(DetectionReplayTest, ConfigValidation)
{
  EXPECT_NO_THROW(groundTruthConfig().validate());
  auto invalid = [](const std::function<void(DetectionReplayConfig&)>& change)
  {
    DetectionReplayConfig config = groundTruthConfig();
    change(config);
    return [config] { config.validate(); };
  };
  EXPECT_THROW(invalid([](DetectionReplayConfig& c) { c.directory.clear(); })(), std::invalid_argument);
  EXPECT_THROW(invalid([](DetectionReplayConfig& c) { c.file_pattern = "%s.txt"; })(), std::invalid_argument);
  EXPECT_THROW(invalid([](DetectionReplayConfig& c) { c.file_pattern = "%d_%d.txt"; })(),
               std::invalid_argument);
  EXPECT_THROW(invalid([](DetectionReplayConfig& c) { c.file_pattern = "frame.txt"; })(),
               std::invalid_argument);
  EXPECT_NO_THROW(invalid([](DetectionReplayConfig& c) { c.file_pattern = "100%% %010d.txt"; })());
  EXPECT_THROW(invalid([](DetectionReplayConfig& c) { c.first_index = -1; })(), std::invalid_argument);
  EXPECT_THROW(invalid([](DetectionReplayConfig& c) { c.default_score = 1.5; })(), std::invalid_argument);
  EXPECT_THROW(invalid(
                   [](DetectionReplayConfig& c) {
                     c.class_map = {{"Car", ""}};
                   })(),
               std::invalid_argument);
  DetectionReplayConfig absent = groundTruthConfig();
  absent.directory = kLabelDir + "/absent";
  EXPECT_THROW(DetectionReplay{absent}, std::invalid_argument);
  EXPECT_EQ(frameIndexSourceFromString("seq"), FrameIndexSource::kHeaderSeq);
  EXPECT_EQ(frameIndexSourceFromString(toString(FrameIndexSource::kCounter)), FrameIndexSource::kCounter);
  EXPECT_THROW(frameIndexSourceFromString("stamp"), std::invalid_argument);
}

}  // namespace
}  // namespace grid_vision_fusion
