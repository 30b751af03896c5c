// KITTI object label reader: real label_2 files, result files with scores, malformed input.
#include <gtest/gtest.h>

#include <sstream>

#include "grid_vision_fusion/core/kitti_labels.h"

namespace grid_vision_fusion
{
namespace
{
const std::string kLabelDir = std::string(GVF_TEST_DATA_DIR) + "/kitti_labels";

TEST(KittiLabelsTest, ReadsARealLabelFile)
{
  const auto labels = readKittiLabels(kLabelDir + "/label_2/000001.txt");
  ASSERT_EQ(labels.size(), 7U);
  const KittiObjectLabel& truck = labels[0];
  EXPECT_EQ(truck.type, "Truck");
  EXPECT_FLOAT_EQ(truck.truncated, 0.F);
  EXPECT_EQ(truck.occluded, 0);
  EXPECT_FLOAT_EQ(truck.alpha, -1.57F);
  EXPECT_FLOAT_EQ(truck.left, 599.41F);
  EXPECT_FLOAT_EQ(truck.top, 156.40F);
  EXPECT_FLOAT_EQ(truck.right, 629.75F);
  EXPECT_FLOAT_EQ(truck.bottom, 189.25F);
  EXPECT_FLOAT_EQ(truck.height, 2.85F);
  EXPECT_FLOAT_EQ(truck.width, 2.63F);
  EXPECT_FLOAT_EQ(truck.length, 12.34F);
  EXPECT_FLOAT_EQ(truck.x, 0.47F);
  EXPECT_FLOAT_EQ(truck.y, 1.49F);
  EXPECT_FLOAT_EQ(truck.z, 69.44F);
  EXPECT_FLOAT_EQ(truck.rotation_y, -1.56F);
  EXPECT_FALSE(truck.score.has_value());
  EXPECT_EQ(labels[2].type, "Cyclist");
  EXPECT_EQ(labels[2].occluded, 3);
  EXPECT_EQ(labels[6].type, "DontCare");
  EXPECT_EQ(labels[6].occluded, -1);
  EXPECT_FLOAT_EQ(labels[6].z, -1000.F);
}

TEST(KittiLabelsTest, ReadsScoresAndSkipsBlankLines)
{
  const auto labels = readKittiLabels(kLabelDir + "/results/000007.txt");
  ASSERT_EQ(labels.size(), 4U);
  ASSERT_TRUE(labels[0].score.has_value());
  EXPECT_FLOAT_EQ(*labels[0].score, 0.91F);
  EXPECT_EQ(labels[3].type, "Cyclist");
  EXPECT_FLOAT_EQ(*labels[3].score, 0.55F);
}

/// Parses `text` and returns the error message (empty when it parsed).
std::string errorOf(const std::string& text)
{
  std::istringstream input(text);
  try
  {
    parseKittiLabels(input, "frame.txt");
  }
  catch (const KittiLabelError& e)
  {
    return e.what();
  }
  return "";
}

TEST(KittiLabelsTest, MalformedLinesNameFileLineAndField)
{
  const std::string good =
      "Car 0.00 0 1.85 387.63 181.54 423.81 203.12 1.67 1.87 3.69 -16.53 2.39 58.49 1.57\n";
  EXPECT_EQ(errorOf(good + "\n" + good), "");
  const std::string short_line = errorOf(good + "Car 0 0 1 2 3\n");
  EXPECT_EQ(short_line.rfind("frame.txt:2: ", 0), 0U) << short_line;
  EXPECT_NE(short_line.find("got 6"), std::string::npos) << short_line;
  const std::string bad_number =
      errorOf("Car 0.00 0 1.85 387.63 18x.54 423.81 203.12 1.67 1.87 3.69 -16.53 2.39 58.49 1.57\n");
  EXPECT_NE(bad_number.find("frame.txt:1: field 6 (top)"), std::string::npos) << bad_number;
  EXPECT_NE(bad_number.find("18x.54"), std::string::npos) << bad_number;
  const std::string bad_occlusion =
      errorOf("Car 0.00 0.5 1.85 387.63 181.54 423.81 203.12 1.67 1.87 3.69 -16.53 2.39 58.49 1.57\n");
  EXPECT_NE(bad_occlusion.find("field 3 (occluded)"), std::string::npos) << bad_occlusion;
  const std::string nan_value =
      errorOf("Car 0.00 0 nan 387.63 181.54 423.81 203.12 1.67 1.87 3.69 -16.53 2.39 58.49 1.57\n");
  EXPECT_NE(nan_value.find("alpha"), std::string::npos) << nan_value;
  const std::string bad_score =
      errorOf("Car 0.00 0 1.85 387.63 181.54 423.81 203.12 1.67 1.87 3.69 -16.53 2.39 58.49 1.57 high\n");
  EXPECT_NE(bad_score.find("score"), std::string::npos) << bad_score;
  const std::string swapped =
      errorOf("Car 0.00 0 1.85 423.81 181.54 387.63 203.12 1.67 1.87 3.69 -16.53 2.39 58.49 1.57\n");
  EXPECT_NE(swapped.find("right < left"), std::string::npos) << swapped;
  const std::string too_long = errorOf("Car 0 0 1 2 3 4 5 6 7 8 9 10 11 12 13 14\n");
  EXPECT_NE(too_long.find("got 17"), std::string::npos) << too_long;
}

TEST(KittiLabelsTest, MissingFileIsNamed)
{
  try
  {
    readKittiLabels(kLabelDir + "/label_2/999999.txt");
    FAIL() << "no error for a missing file";
  }
  catch (const KittiLabelError& e)
  {
    EXPECT_NE(std::string(e.what()).find("999999.txt"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace grid_vision_fusion
