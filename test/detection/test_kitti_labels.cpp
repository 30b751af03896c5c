// KITTI object label reader: real label_2 files, result files with scores, malformed input; the
// writer (every line parses back to the same label) and detections as result lines.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <sstream>

#include "grid_vision_fusion/detection/kitti_labels.h"
#include "grid_vision_fusion/detection/kitti_results.h"
#include "tiny_darknet.h"

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

void expectSameLabel(const KittiObjectLabel& a, const KittiObjectLabel& b)
{
  EXPECT_EQ(a.type, b.type);
  EXPECT_EQ(a.truncated, b.truncated);
  EXPECT_EQ(a.occluded, b.occluded);
  const float as[] = {a.alpha, a.left,   a.top, a.right, a.bottom, a.height,
                      a.width, a.length, a.x,   a.y,     a.z,      a.rotation_y};
  const float bs[] = {b.alpha, b.left,   b.top, b.right, b.bottom, b.height,
                      b.width, b.length, b.x,   b.y,     b.z,      b.rotation_y};
  for (std::size_t i = 0; i < 12; ++i)
  {
    EXPECT_EQ(as[i], bs[i]) << "field " << i + 4;  // exactly: the shortest form reads back the same float
  }
  EXPECT_EQ(a.score, b.score);
}

TEST(KittiLabelsTest, FormattedLinesParseBackExactly)
{
  const auto labels = readKittiLabels(kLabelDir + "/label_2/000001.txt");
  KittiObjectLabel awkward;  // floats without a short decimal form, a score, extreme magnitudes
  awkward.type = "Person_sitting";
  awkward.truncated = 1.F / 3.F;
  awkward.occluded = 3;
  awkward.alpha = -3.14159265F;
  awkward.left = 0.1F;
  awkward.top = 1e-7F;
  awkward.right = 1241.999F;
  awkward.bottom = 374.5F;
  awkward.x = -1e30F;
  awkward.score = std::nextafter(0.5F, 1.F);
  std::vector<KittiObjectLabel> all = labels;
  all.push_back(awkward);
  std::string text;
  for (const KittiObjectLabel& label : all)
  {
    text += formatKittiLabel(label) + "\n";
  }
  std::istringstream input(text);
  const auto parsed = parseKittiLabels(input, "formatted");
  ASSERT_EQ(parsed.size(), all.size());
  for (std::size_t i = 0; i < all.size(); ++i)
  {
    expectSameLabel(parsed[i], all[i]);
  }
  EXPECT_EQ(formatKittiLabel(labels[0]),
            "Truck 0 0 -1.57 599.41 156.4 629.75 189.25 2.85 2.63 12.34 0.47 1.49 69.44 -1.56");
}

TEST(KittiLabelsTest, FormatRefusesWhatWouldNotParse)
{
  KittiObjectLabel label;
  label.type = "traffic light";
  EXPECT_THROW(formatKittiLabel(label), std::invalid_argument);
  label.type = "";
  EXPECT_THROW(formatKittiLabel(label), std::invalid_argument);
  label.type = "Car";
  label.left = std::numeric_limits<float>::quiet_NaN();
  EXPECT_THROW(formatKittiLabel(label), std::invalid_argument);
}

TEST(KittiLabelsTest, WriteReplacesTheFileAtOnceAndNamesAFailure)
{
  const std::string dir = test::makeTempDirectory();
  const std::string path = dir + "/000003.txt";
  std::ofstream(path) << "an earlier file\n";
  KittiObjectLabel label;
  label.type = "Car";
  label.right = 10.F;
  label.bottom = 5.F;
  writeKittiLabels(path, {label, label});
  EXPECT_EQ(readKittiLabels(path).size(), 2U);
  writeKittiLabels(path, {});
  std::ifstream written(path);
  EXPECT_EQ(std::string(std::istreambuf_iterator<char>(written), std::istreambuf_iterator<char>()), "");
  EXPECT_FALSE(std::filesystem::exists(path + ".tmp"));
  try
  {
    writeKittiLabels(dir + "/no_such_folder/000003.txt", {label});
    FAIL() << "no error for a folder that does not exist";
  }
  catch (const KittiLabelError& e)
  {
    EXPECT_NE(std::string(e.what()).find(dir + "/no_such_folder/000003.txt"), std::string::npos) << e.what();
  }
  std::filesystem::remove_all(dir);
}

TEST(KittiResultsTest, LabelsBecomeKittiTypes)
{
  EXPECT_EQ(kittiTypeOfLabel("car"), "Car");
  EXPECT_EQ(kittiTypeOfLabel("pedestrian"), "Pedestrian");
  EXPECT_EQ(kittiTypeOfLabel("PERSON_SITTING"), "Person_sitting");
  EXPECT_EQ(kittiTypeOfLabel("Van"), "Van");
  EXPECT_EQ(kittiTypeOfLabel("traffic light"), "traffic_light");
  EXPECT_EQ(kittiTypeOfLabel("person"), "person");
  EXPECT_THROW(kittiTypeOfLabel(""), std::invalid_argument);
}

TEST(KittiResultsTest, ADetectionIsA2dResultLineWithUnknown3dFields)
{
  Detection detection;
  detection.label = "cyclist";
  detection.score = 0.8125F;
  detection.box = {10.5F, 20.25F, 30.F, 60.F};
  EXPECT_EQ(formatKittiLabel(kittiResultOf(detection)),
            "Cyclist -1 -1 -10 10.5 20.25 30 60 -1 -1 -1 -1000 -1000 -1000 -10 0.8125");
}

}  // namespace
}  // namespace grid_vision_fusion
