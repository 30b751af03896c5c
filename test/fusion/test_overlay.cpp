// Tests of the overlay drawing: colours land where the objects are.
#include <gtest/gtest.h>

#include <opencv2/core.hpp>

#include "grid_vision_fusion/fusion/overlay.h"

namespace grid_vision_fusion
{
namespace
{
cv::Vec3b at(const cv::Mat& image, int u, int v)
{
  return image.at<cv::Vec3b>(v, u);
}
}  // namespace

TEST(Overlay, LabelText)
{
  EXPECT_EQ(objectLabel(Motion::kDynamic, "car", 4.24), "dynamic car 4.2 m/s");
  EXPECT_EQ(objectLabel(Motion::kStatic, "van", 3.0), "static van");
  EXPECT_EQ(objectLabel(Motion::kUnknown, "truck", 0.0), "unknown truck");
}

TEST(Overlay, BoxesColouredByMotionAndPointsByState)
{
  cv::Mat image(200, 300, CV_8UC3, cv::Scalar(0, 0, 0));
  Detection moving;
  moving.label = "car";
  moving.box = BoundingBox{20.F, 60.F, 120.F, 140.F};
  Detection parked;
  parked.label = "van";
  parked.box = BoundingBox{160.F, 60.F, 260.F, 140.F};
  ProjectedPoints points;
  points.add(70.F, 150.F, 10.F, 1.F, 5.F, 0.F, CellState::kDynamic);
  points.add(210.F, 150.F, 12.F, -3.F, 0.F, 0.F, CellState::kStatic);
  const FusionConfig config;
  FusionResult result = fuse({moving, parked}, points.view(), config);
  ASSERT_EQ(result.objects.size(), 2U);
  reportPerFrame(result, {moving, parked}, config.position);

  drawFusionOverlay(image, {moving, parked}, result, points.view(), config);
  // Left edge of each box (thickness 2), below the label: the motion colour.
  EXPECT_EQ(at(image, 20, 100), cv::Vec3b(0, 200, 0));   // dynamic: green
  EXPECT_EQ(at(image, 160, 100), cv::Vec3b(255, 0, 0));  // static: blue
  // The projected points: dynamic green, static blue.
  EXPECT_EQ(at(image, 70, 150), cv::Vec3b(0, 200, 0));
  EXPECT_EQ(at(image, 210, 150), cv::Vec3b(255, 0, 0));
  // Fusion band bottom edge of the parked van: y_max + h/4 = 160, red.
  EXPECT_EQ(at(image, 230, 160), cv::Vec3b(0, 0, 255));
  // Far from everything: untouched.
  EXPECT_EQ(at(image, 140, 20), cv::Vec3b(0, 0, 0));
}

TEST(Overlay, ANewTrackIsDrawnGrey)
{
  cv::Mat image(200, 300, CV_8UC3, cv::Scalar(0, 0, 0));
  Detection moving;
  moving.label = "car";
  moving.box = BoundingBox{20.F, 60.F, 120.F, 140.F};
  ProjectedPoints points;
  points.add(70.F, 150.F, 10.F, 1.F, 5.F, 0.F, CellState::kDynamic);
  const FusionConfig config;
  FusionResult result = fuse({moving}, points.view(), config);
  ASSERT_EQ(result.objects.size(), 1U);
  reportPerFrame(result, {moving}, config.position);
  result.tracked = true;
  result.reports[0].track_state = TrackState::kTentative;
  drawFusionOverlay(image, {moving}, result, points.view(), config);
  const cv::Vec3b edge = at(image, 20, 100);
  EXPECT_EQ(edge[0], edge[1]);
  EXPECT_EQ(edge[1], edge[2]) << "grey, not the dynamic green";
  EXPECT_GT(edge[0], 0);
}

TEST(Overlay, RejectsNonBgrImages)
{
  cv::Mat mono(10, 10, CV_8UC1);
  EXPECT_THROW(drawProjectedPoints(mono, ProjectedPoints{}.view()), std::invalid_argument);
}

TEST(Overlay, PointsOutsideTheImageAreSkipped)
{
  cv::Mat image(10, 10, CV_8UC3, cv::Scalar(0, 0, 0));
  ProjectedPoints points;
  points.add(-5.F, 3.F, 0.F, 0.F, 0.F, 0.F, CellState::kStatic);
  points.add(3.F, 50.F, 0.F, 0.F, 0.F, 0.F, CellState::kStatic);
  drawProjectedPoints(image, points.view(), 1);
  EXPECT_EQ(cv::countNonZero(image.reshape(1)), 0);
}

}  // namespace grid_vision_fusion
