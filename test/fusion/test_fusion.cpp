// Unit tests of the fusion regions and the point-wise feature processing. Every expectation is
// computed by hand in the comment next to it.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <map>
#include <stdexcept>

#include "grid_vision_fusion/fusion/fusion.h"

namespace grid_vision_fusion
{
namespace
{
constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

Detection makeDetection(float x_min, float y_min, float x_max, float y_max, const std::string& label = "car",
                        float score = 0.9F)
{
  Detection d;
  d.label = label;
  d.score = score;
  d.box = BoundingBox{x_min, y_min, x_max, y_max};
  return d;
}

// Box (100, 100)–(200, 180): h = 80, band v ∈ (180 − 20, 180 + 20) = (160, 200), u ∈ (100, 200).
const Detection kBox = makeDetection(100.F, 100.F, 200.F, 180.F);

void addStatic(ProjectedPoints& pts, float u, float v, float x, float y)
{
  pts.add(u, v, x, y, 0.F, 0.F, CellState::kStatic);
}
void addDynamic(ProjectedPoints& pts, float u, float v, float x, float y, float vx, float vy)
{
  pts.add(u, v, x, y, vx, vy, CellState::kDynamic);
}

// The paper's decision rule, the default: every cell of the fusion band votes (stated, as these
// tests check that rule whatever the default).
/// fuse(), then the paper's per-frame report of every object, positions at the median.
FusionResult fuseAndReport(const std::vector<Detection>& detections, const ProjectedPointsView& points,
                           const FusionConfig& config)
{
  FusionResult result = fuse(detections, points, config);
  reportPerFrame(result, detections, PositionSource::kMedian);
  return result;
}

FusionConfig paperRule()
{
  FusionConfig config;
  config.motion_vote = MotionVote::kRegion;
  return config;
}
}  // namespace

TEST(FusionRegion, BandLimitsFollowThePaper)
{
  const FusionConfig config;
  const FusionRegion region = FusionRegion::fromBox(kBox.box, config);
  // Paper: Y_low = (3·180 + 100)/4 = 160, Y_high = (5·180 − 100)/4 = 200.
  EXPECT_FLOAT_EQ(region.v_min, 160.F);
  EXPECT_FLOAT_EQ(region.v_max, 200.F);
  EXPECT_FLOAT_EQ(region.u_min, 100.F);
  EXPECT_FLOAT_EQ(region.u_max, 200.F);
}

TEST(FusionRegion, BandFractionsAreParameters)
{
  FusionConfig config;
  config.band_above = 0.5;  // 40 px above 180
  config.band_below = 0.1;  // 8 px below 180
  const FusionRegion region = FusionRegion::fromBox(kBox.box, config);
  EXPECT_FLOAT_EQ(region.v_min, 140.F);
  EXPECT_FLOAT_EQ(region.v_max, 188.F);
}

TEST(FusionRegion, StrictInequalitiesAtTheBorders)
{
  const FusionRegion region = FusionRegion::fromBox(kBox.box, FusionConfig{});
  EXPECT_TRUE(region.contains(150.F, 180.F));
  EXPECT_TRUE(region.contains(100.01F, 160.01F));
  EXPECT_TRUE(region.contains(199.99F, 199.99F));
  // Exactly on each border: outside.
  EXPECT_FALSE(region.contains(100.F, 180.F));
  EXPECT_FALSE(region.contains(200.F, 180.F));
  EXPECT_FALSE(region.contains(150.F, 160.F));
  EXPECT_FALSE(region.contains(150.F, 200.F));
  // Inside the box but above the band (the body of the car): outside.
  EXPECT_FALSE(region.contains(150.F, 120.F));
  EXPECT_FALSE(region.contains(kNaN, 180.F));
  EXPECT_FALSE(region.contains(150.F, kNaN));
}

TEST(FusionConfig, ValidateRejectsBadValues)
{
  FusionConfig config;
  EXPECT_NO_THROW(config.validate());
  config.band_above = -0.1;
  EXPECT_THROW(config.validate(), std::invalid_argument);
  config = FusionConfig{};
  config.band_below = std::nan("");
  EXPECT_THROW(config.validate(), std::invalid_argument);
  config = FusionConfig{};
  config.min_points = 0;
  try
  {
    config.validate();
    FAIL() << "min_points = 0 accepted";
  }
  catch (const std::invalid_argument& e)
  {
    EXPECT_NE(std::string(e.what()).find("min_points"), std::string::npos);
  }
}

TEST(FusionConfig, TieRuleNames)
{
  EXPECT_EQ(tieRuleFromString("static"), TieRule::kStatic);
  EXPECT_EQ(tieRuleFromString("dynamic"), TieRule::kDynamic);
  EXPECT_EQ(tieRuleFromString("unknown"), TieRule::kUnknown);
  EXPECT_EQ(toString(TieRule::kDynamic), "dynamic");
  EXPECT_THROW(tieRuleFromString("Static"), std::invalid_argument);
}

TEST(Median, OddAndEvenCounts)
{
  std::vector<double> odd{5.0, 1.0, 3.0};
  EXPECT_DOUBLE_EQ(median(odd), 3.0);
  std::vector<double> even{4.0, 1.0, 3.0, 10.0};  // sorted 1 3 4 10 → (3 + 4)/2
  EXPECT_DOUBLE_EQ(median(even), 3.5);
  std::vector<double> one{-2.0};
  EXPECT_DOUBLE_EQ(median(one), -2.0);
  std::vector<double> empty;
  EXPECT_THROW(median(empty), std::invalid_argument);
}

TEST(DecideMotion, LargerCardinalityTiesAndMinimum)
{
  FusionConfig config = paperRule();
  EXPECT_EQ(decideMotion(3, 1, config), Motion::kStatic);
  EXPECT_EQ(decideMotion(1, 3, config), Motion::kDynamic);
  EXPECT_EQ(decideMotion(0, 0, config), Motion::kUnknown);
  EXPECT_EQ(decideMotion(2, 2, config), Motion::kStatic);  // default tie rule
  config.tie_rule = TieRule::kDynamic;
  EXPECT_EQ(decideMotion(2, 2, config), Motion::kDynamic);
  config.tie_rule = TieRule::kUnknown;
  EXPECT_EQ(decideMotion(2, 2, config), Motion::kUnknown);
  config.min_points = 4;
  EXPECT_EQ(decideMotion(3, 1, config), Motion::kUnknown);  // winner 3 < 4
  EXPECT_EQ(decideMotion(1, 4, config), Motion::kDynamic);  // winner 4 >= 4
}

TEST(Fuse, EmptyRegionGivesAnObjectWithoutSupport)
{
  ProjectedPoints pts;
  addStatic(pts, 150.F, 120.F, 10.F, 0.F);  // inside the box, above the band
  addStatic(pts, 300.F, 180.F, 10.F, 0.F);  // right of the box
  const FusionResult result = fuse({kBox}, pts.view(), paperRule());
  ASSERT_EQ(result.objects.size(), 1U);
  const FusedObject& object = result.objects[0];
  EXPECT_EQ(object.support, ObjectSupport::kBox);
  EXPECT_EQ(object.vote, Motion::kUnknown);
  EXPECT_EQ(object.static_points + object.dynamic_points, 0U);
  EXPECT_DOUBLE_EQ(object.dynamic_share, 0.5);
  EXPECT_TRUE(std::isnan(object.median_x)) << "placeOnGround() gives it a position";
  EXPECT_TRUE(std::isnan(object.centre_x));
  EXPECT_EQ(result.invalid_points, 0U);
}

TEST(Fuse, NoDetectionsAndNoPoints)
{
  EXPECT_TRUE(fuse({}, ProjectedPoints{}.view(), FusionConfig{}).objects.empty());
  const FusionResult result = fuseAndReport({kBox, kBox}, ProjectedPoints{}.view(), FusionConfig{});
  ASSERT_EQ(result.objects.size(), 2U);
  ASSERT_EQ(result.reports.size(), 2U);
  EXPECT_EQ(result.reports[1].id, 1U);
  EXPECT_EQ(result.objects[1].detection_index, 1U);
}

// A camera 1.5 m above the ground plane z = 0 at the origin of the grid frame, looking along +x
// (x forward, y left, z up in the grid frame; x right, y down, z forward in the camera's), focal
// length 500 px, principal point (320, 240).
ImageGround levelCamera()
{
  Eigen::Matrix<double, 3, 4> k_rt;
  k_rt << 320.0, -500.0, 0.0, 0.0,  // u = 320 - 500 y / x
      240.0, 0.0, -500.0, 750.0,    // v = 240 - 500 (z - 1.5) / x
      1.0, 0.0, 0.0, 0.0;           // w = x
  ImageGround ground;
  ground.grid_to_image = k_rt;
  ground.ground_z = 0.0;
  return ground;
}

TEST(ImageGround, LineOfSightMeetsTheGroundOrTheRangeLimit)
{
  const ImageGround ground = levelCamera();
  ASSERT_TRUE(ground.valid());
  EXPECT_TRUE(ground.cameraPosition().isZero(1e-12));
  // v = 240 + 750 / x: the bottom edge at v = 315 looks at the ground 10 m ahead; u = 370 is
  // 50 px right of the centre: y = -50 x / 500 = -1 m.
  const Eigen::Vector2d foot = ground.groundPoint(370.0, 315.0, 150.0);
  EXPECT_NEAR(foot.x(), 10.0, 1e-9);
  EXPECT_NEAR(foot.y(), -1.0, 1e-9);
  // On the horizon (v = 240) or above it the line never meets the ground: the range limit
  // along its horizontal direction.
  const Eigen::Vector2d far = ground.groundPoint(320.0, 200.0, 150.0);
  EXPECT_NEAR(far.x(), 150.0, 1e-9);
  EXPECT_NEAR(far.y(), 0.0, 1e-9);
  // Just below the horizon, beyond the limit: the limit.
  EXPECT_NEAR(ground.groundPoint(320.0, 241.0, 150.0).x(), 150.0, 1e-9);
  EXPECT_FALSE(ImageGround{}.valid()) << "all zeros: the projected grid did not carry it";
}

TEST(PlaceOnGround, BoxWithoutCellsStandsOnTheGroundBehindItsBottomEdge)
{
  const Detection car = makeDetection(300.F, 200.F, 340.F, 315.F, "car");
  ProjectedPoints pts;
  addStatic(pts, 150.F, 170.F, 7.F, 1.F);  // kBox's cell
  FusionResult result = fuse({kBox, car}, pts.view(), paperRule());
  ASSERT_EQ(result.objects.size(), 2U);
  result.objects[0].centre_x = 7.0;  // as estimateCentres() leaves it
  const std::map<std::string, Footprint> footprints{{"car", {3.9, 1.6}}};
  placeOnGround(result, {kBox, car}, levelCamera(), footprints);
  EXPECT_DOUBLE_EQ(result.objects[0].centre_x, 7.0) << "an object with cells keeps its position";
  // The bottom centre (320, 315) looks at (10, 0); half the mean of 3.9 and 1.6 m beyond it.
  EXPECT_NEAR(result.objects[1].centre_x, 10.0 + 0.25 * (3.9 + 1.6), 1e-9);
  EXPECT_NEAR(result.objects[1].centre_y, 0.0, 1e-9);
  EXPECT_EQ(result.objects[1].position(PositionSource::kMedian),
            result.objects[1].position(PositionSource::kCentre))
      << "its median is the same place";
  EXPECT_EQ(result.objects[1].support, ObjectSupport::kBox);
}

TEST(Fuse, OnlyStaticPointsOddMedian)
{
  ProjectedPoints pts;
  addStatic(pts, 120.F, 170.F, 10.F, 2.F);
  addStatic(pts, 150.F, 180.F, 12.F, 1.F);
  addStatic(pts, 180.F, 190.F, 11.F, 5.F);
  const FusionResult result = fuseAndReport({kBox}, pts.view(), paperRule());
  ASSERT_EQ(result.objects.size(), 1U);
  const FusedObject& o = result.objects[0];
  EXPECT_EQ(o.detection_index, 0U);
  EXPECT_EQ(o.vote, Motion::kStatic);
  EXPECT_EQ(o.static_points, 3U);
  EXPECT_EQ(o.dynamic_points, 0U);
  EXPECT_DOUBLE_EQ(o.median_x, 11.0);  // median of 10, 12, 11
  EXPECT_DOUBLE_EQ(o.median_y, 2.0);   // median of 2, 1, 5
  const ReportedObject& r = result.reports.at(0);
  EXPECT_EQ(r.motion, Motion::kStatic);
  EXPECT_DOUBLE_EQ(r.x, 11.0);
  EXPECT_DOUBLE_EQ(r.y, 2.0);
  EXPECT_DOUBLE_EQ(r.vx, 0.0);
  EXPECT_DOUBLE_EQ(r.vy, 0.0);
  EXPECT_DOUBLE_EQ(r.heading, 0.0);
  EXPECT_EQ(r.label, kBox.label);
  EXPECT_EQ(r.track_state, TrackState::kNone);
}

TEST(Fuse, DynamicMajorityEvenMedians)
{
  ProjectedPoints pts;
  addDynamic(pts, 110.F, 170.F, 20.F, 1.F, 4.F, 1.F);
  addDynamic(pts, 120.F, 175.F, 21.F, 2.F, 6.F, 3.F);
  addDynamic(pts, 130.F, 185.F, 22.F, 3.F, 5.F, 2.F);
  addStatic(pts, 140.F, 190.F, 30.F, 4.F);
  // Position over all 4 points: x sorted 20 21 22 30 → 21.5; y sorted 1 2 3 4 → 2.5.
  // Velocity over the 3 dynamic points: vx sorted 4 5 6 → 5; vy sorted 1 2 3 → 2.
  const FusionResult result = fuseAndReport({kBox}, pts.view(), paperRule());
  ASSERT_EQ(result.objects.size(), 1U);
  const FusedObject& o = result.objects[0];
  EXPECT_EQ(o.vote, Motion::kDynamic);
  EXPECT_EQ(o.static_points, 1U);
  EXPECT_EQ(o.dynamic_points, 3U);
  EXPECT_DOUBLE_EQ(o.dynamic_share, 0.75);
  const ReportedObject& r = result.reports.at(0);
  EXPECT_EQ(r.motion, Motion::kDynamic);
  EXPECT_DOUBLE_EQ(r.p_dynamic, 0.75);
  EXPECT_DOUBLE_EQ(r.x, 21.5);
  EXPECT_DOUBLE_EQ(r.y, 2.5);
  EXPECT_DOUBLE_EQ(r.vx, 5.0);
  EXPECT_DOUBLE_EQ(r.vy, 2.0);
  EXPECT_NEAR(r.heading, std::atan2(2.0, 5.0), 1e-12);
  EXPECT_NEAR(r.speed(), std::sqrt(29.0), 1e-12);
}

TEST(Fuse, EvenVelocityMedian)
{
  ProjectedPoints pts;
  addDynamic(pts, 110.F, 170.F, 0.F, 0.F, 1.F, -1.F);
  addDynamic(pts, 120.F, 170.F, 0.F, 0.F, 3.F, -5.F);
  // vx (1 + 3)/2 = 2, vy (−1 − 5)/2 = −3
  const FusionResult result = fuse({kBox}, pts.view(), paperRule());
  ASSERT_EQ(result.objects.size(), 1U);
  EXPECT_DOUBLE_EQ(result.objects[0].vote_vx, 2.0);
  EXPECT_DOUBLE_EQ(result.objects[0].vote_vy, -3.0);
}

TEST(Fuse, TieFollowsTheRule)
{
  ProjectedPoints pts;
  addStatic(pts, 110.F, 170.F, 1.F, 1.F);
  addDynamic(pts, 120.F, 170.F, 3.F, 3.F, 2.F, 0.F);
  FusionConfig config = paperRule();
  EXPECT_EQ(fuse({kBox}, pts.view(), config).objects.at(0).vote, Motion::kStatic);
  config.tie_rule = TieRule::kDynamic;
  const FusedObject dynamic = fuse({kBox}, pts.view(), config).objects.at(0);
  EXPECT_EQ(dynamic.vote, Motion::kDynamic);
  EXPECT_DOUBLE_EQ(dynamic.vote_vx, 2.0);
  config.tie_rule = TieRule::kUnknown;
  const ReportedObject unknown = fuseAndReport({kBox}, pts.view(), config).reports.at(0);
  EXPECT_EQ(unknown.motion, Motion::kUnknown);
  EXPECT_DOUBLE_EQ(unknown.vx, 0.0);
  EXPECT_DOUBLE_EQ(unknown.x, 2.0);  // position still reported: (1 + 3)/2
}

TEST(Fuse, MinimumPointCountGivesUnknown)
{
  ProjectedPoints pts;
  addDynamic(pts, 110.F, 170.F, 5.F, 6.F, 2.F, 0.F);
  FusionConfig config = paperRule();
  config.min_points = 2;
  const FusionResult result = fuseAndReport({kBox}, pts.view(), config);
  ASSERT_EQ(result.objects.size(), 1U);
  EXPECT_EQ(result.objects[0].vote, Motion::kUnknown);
  EXPECT_EQ(result.objects[0].dynamic_points, 1U);
  EXPECT_DOUBLE_EQ(result.reports.at(0).x, 5.0);
  EXPECT_DOUBLE_EQ(result.reports.at(0).heading, 0.0);
}

TEST(Fuse, HeadingInAllFourQuadrants)
{
  struct Case
  {
    float vx, vy;
    double heading;
  };
  const Case cases[] = {{1.F, 1.F, M_PI / 4},         // quadrant I
                        {-1.F, 1.F, 3 * M_PI / 4},    // quadrant II
                        {-1.F, -1.F, -3 * M_PI / 4},  // quadrant III
                        {1.F, -1.F, -M_PI / 4},       // quadrant IV
                        {0.F, 2.F, M_PI / 2},         // +y axis
                        {-3.F, 0.F, M_PI}};           // −x axis
  for (const Case& c : cases)
  {
    ProjectedPoints pts;
    addDynamic(pts, 150.F, 180.F, 0.F, 0.F, c.vx, c.vy);
    const FusionResult result = fuseAndReport({kBox}, pts.view(), paperRule());
    ASSERT_EQ(result.reports.size(), 1U);
    EXPECT_NEAR(result.reports[0].heading, c.heading, 1e-6) << "v = (" << c.vx << ", " << c.vy << ")";
  }
}

TEST(Fuse, OverlappingBoxesShareByDefault)
{
  // Near car: box (100,100)-(200,180), band v in (160, 200).
  // Far car partly hidden behind it: box (150,120)-(250,170), h = 50, band v in (157.5, 182.5).
  const Detection near_car = kBox;
  const Detection far_car = makeDetection(150.F, 120.F, 250.F, 170.F, "van", 0.8F);
  ProjectedPoints pts;
  addStatic(pts, 170.F, 175.F, 10.F, 0.F);             // in both bands
  addDynamic(pts, 230.F, 165.F, 25.F, 0.F, 3.F, 0.F);  // far band only
  addStatic(pts, 120.F, 190.F, 9.F, 1.F);              // near band only

  const FusionResult shared = fuse({near_car, far_car}, pts.view(), paperRule());
  ASSERT_EQ(shared.objects.size(), 2U);
  EXPECT_EQ(shared.objects[0].detection_index, 0U);
  EXPECT_EQ(shared.objects[0].static_points, 2U);
  EXPECT_EQ(shared.objects[0].dynamic_points, 0U);
  EXPECT_EQ(shared.objects[1].detection_index, 1U);
  EXPECT_EQ(shared.objects[1].static_points, 1U);
  EXPECT_EQ(shared.objects[1].dynamic_points, 1U);

  // Exclusive: the shared point belongs to the box whose bottom is lowest (near car, 180 > 170).
  FusionConfig exclusive = paperRule();
  exclusive.exclusive_assignment = true;
  const FusionResult owned = fuse({far_car, near_car}, pts.view(), exclusive);
  ASSERT_EQ(owned.objects.size(), 2U);
  EXPECT_EQ(owned.objects[0].detection_index, 0U);  // far car, listed first
  EXPECT_EQ(owned.objects[0].static_points, 0U);
  EXPECT_EQ(owned.objects[0].dynamic_points, 1U);
  EXPECT_EQ(owned.objects[0].vote, Motion::kDynamic);
  EXPECT_EQ(owned.objects[1].static_points, 2U);
}

TEST(Fuse, ExclusiveTieOnBottomGoesToHigherScore)
{
  const Detection low_score = makeDetection(100.F, 100.F, 200.F, 180.F, "car", 0.5F);
  const Detection high_score = makeDetection(120.F, 140.F, 220.F, 180.F, "van", 0.9F);
  ProjectedPoints pts;
  addStatic(pts, 150.F, 178.F, 1.F, 1.F);  // in both bands
  FusionConfig config = paperRule();
  config.exclusive_assignment = true;
  const FusionResult result = fuse({low_score, high_score}, pts.view(), config);
  ASSERT_EQ(result.objects.size(), 2U);
  EXPECT_EQ(result.objects[0].support, ObjectSupport::kBox) << "the point went to the other box";
  EXPECT_EQ(result.objects[1].detection_index, 1U);
  EXPECT_EQ(result.objects[1].static_points, 1U);
}

TEST(Fuse, NaNCoordinatesAreIgnored)
{
  ProjectedPoints pts;
  addStatic(pts, kNaN, 180.F, 1.F, 1.F);
  addStatic(pts, 150.F, kNaN, 1.F, 1.F);
  addStatic(pts, 150.F, 180.F, kNaN, 1.F);
  addStatic(pts, 150.F, 180.F, 1.F, std::numeric_limits<float>::infinity());
  addDynamic(pts, 150.F, 180.F, 1.F, 1.F, kNaN, 0.F);  // dynamic without a velocity
  addStatic(pts, 150.F, 180.F, 4.F, 6.F);              // the only valid point
  pts.state.push_back(7);                              // an invalid state on a 7th point
  for (auto* array : {&pts.u, &pts.v, &pts.x, &pts.y, &pts.vx, &pts.vy})
  {
    array->push_back(150.F);
  }
  const FusionResult result = fuse({kBox}, pts.view(), paperRule());
  EXPECT_EQ(result.invalid_points, 6U);
  ASSERT_EQ(result.objects.size(), 1U);
  EXPECT_EQ(result.objects[0].static_points, 1U);
  EXPECT_EQ(result.objects[0].dynamic_points, 0U);
  EXPECT_DOUBLE_EQ(result.objects[0].median_x, 4.0);
  EXPECT_DOUBLE_EQ(result.objects[0].median_y, 6.0);
}

TEST(Fuse, StaticPointVelocityIsNotUsed)
{
  ProjectedPoints pts;
  pts.add(150.F, 180.F, 1.F, 2.F, kNaN, kNaN, CellState::kStatic);  // velocity irrelevant
  const FusionResult result = fuse({kBox}, pts.view(), paperRule());
  EXPECT_EQ(result.invalid_points, 0U);
  ASSERT_EQ(result.objects.size(), 1U);
  EXPECT_EQ(result.objects[0].vote, Motion::kStatic);
}

TEST(FusionConfig, MotionVoteNames)
{
  EXPECT_EQ(motionVoteFromString("region"), MotionVote::kRegion);
  EXPECT_EQ(motionVoteFromString("cluster"), MotionVote::kCluster);
  EXPECT_EQ(toString(MotionVote::kCluster), "cluster");
  EXPECT_THROW(motionVoteFromString("box"), std::invalid_argument);
}

// A pedestrian (4 dynamic cells at the bottom edge, 10–10.3 m) in front of a wall (7 static
// cells 3 m behind, projected 19 px = 24 % of the box height above the bottom edge): the
// region's vote is 7 static : 4 dynamic, the pedestrian's own cluster votes 0 : 4 (the wall's
// cells weigh exp(−((19 − 8)/8)²) = 0.15 each in the choice of the cluster: 1.1 against 4).
TEST(Fuse, ClusterVoteLeavesOutTheCellsAroundTheObject)
{
  ProjectedPoints pts;
  const float vx[] = {1.0F, 1.2F, 1.4F, 1.6F};
  for (int k = 0; k < 4; ++k)
  {
    addDynamic(pts, 140.F + 5.F * static_cast<float>(k), 178.F, 10.F + 0.1F * static_cast<float>(k), 0.2F,
               vx[k], 0.F);
  }
  for (int k = 0; k < 7; ++k)
  {
    addStatic(pts, 120.F + 10.F * static_cast<float>(k), 161.F, 13.F, -1.F + 0.2F * static_cast<float>(k));
  }
  FusionConfig config = paperRule();
  const FusionResult region = fuse({kBox}, pts.view(), config);
  ASSERT_EQ(region.objects.size(), 1U);
  EXPECT_EQ(region.objects[0].vote, Motion::kStatic);
  EXPECT_EQ(region.objects[0].static_points, 7U);

  config.motion_vote = MotionVote::kCluster;
  const FusionResult cluster = fuse({kBox}, pts.view(), config);
  ASSERT_EQ(cluster.objects.size(), 1U);
  const FusedObject& o = cluster.objects[0];
  EXPECT_EQ(o.vote, Motion::kDynamic);
  EXPECT_EQ(o.static_points, 0U);
  EXPECT_EQ(o.dynamic_points, 4U);
  EXPECT_FLOAT_EQ(o.vote_vx, 1.3F);  // median of 1.0, 1.2, 1.4, 1.6
  // The position stays the region's median (the paper's): the 6th of the 11 x values sorted.
  EXPECT_FLOAT_EQ(o.median_x, 13.F);
  EXPECT_EQ(o.members.size(), 11U);
}

// The grid's evidence about an object comes from its own cluster, static cells included: 5 cells
// of a slow car whose mass has turned mostly static carry its particles' velocity (3.0–3.4 m/s
// along x); the wall behind it (another cluster) does not count. The cells' dynamic shares
// weigh their velocities; the variance adds the particles' spread and the spread of the means.
TEST(Fuse, GridEvidenceComesFromTheClustersCells)
{
  ProjectedPoints pts;
  const float vx[] = {3.0F, 3.1F, 3.2F, 3.3F, 3.4F};
  for (int k = 0; k < 5; ++k)
  {
    pts.add(140.F + 5.F * static_cast<float>(k), 178.F, 10.F + 0.1F * static_cast<float>(k), 0.2F, vx[k],
            0.1F, k == 0 ? CellState::kDynamic : CellState::kStatic);
    pts.p_static.push_back(k == 0 ? 0.2F : 0.6F);
    pts.p_dynamic.push_back(k == 0 ? 0.6F : 0.2F);
    pts.v_var_x.push_back(0.5F);
    pts.v_var_y.push_back(0.5F);
  }
  for (int k = 0; k < 3; ++k)
  {
    pts.add(120.F + 10.F * static_cast<float>(k), 161.F, 13.F, -1.F + 0.2F * static_cast<float>(k), -9.F, 0.F,
            CellState::kStatic);
    pts.p_static.push_back(0.9F);
    pts.p_dynamic.push_back(0.0F);
    pts.v_var_x.push_back(30.F);
    pts.v_var_y.push_back(30.F);
  }
  const FusionResult result = fuse({kBox}, pts.view(), FusionConfig{});
  ASSERT_EQ(result.objects.size(), 1U);
  const FusedObject& o = result.objects[0];
  EXPECT_EQ(o.cluster.size(), 5U);
  EXPECT_NEAR(o.grid.dynamic_share, (0.75 + 4 * 0.25) / 5.0, 1e-6);
  ASSERT_TRUE(o.grid.has_velocity);
  // Weights 0.75, 0.25 × 4: (0.75 · 3.0 + 0.25 · (3.1 + 3.2 + 3.3 + 3.4)) / 1.75.
  EXPECT_NEAR(o.grid.velocity.x(), (0.75 * 3.0 + 0.25 * 13.0) / 1.75, 1e-5);
  EXPECT_NEAR(o.grid.velocity.y(), 0.1, 1e-6);
  EXPECT_GT(o.grid.velocity_variance.x(), 0.5);
  EXPECT_LT(o.grid.velocity_variance.x(), 0.6);
  EXPECT_NEAR(o.grid.velocity_variance.y(), 0.5, 1e-5);
  EXPECT_EQ(o.vote, Motion::kStatic);  // the states: 4 static cells against 1
  EXPECT_NEAR(o.dynamic_share, 1.0 / 8.0, 1e-12) << "the region's vote: 1 dynamic of 8 cells";

  // Without masses and variances (a view that does not carry them) the states give the share
  // and there is no velocity evidence.
  ProjectedPoints bare = pts;
  bare.p_static.clear();
  bare.p_dynamic.clear();
  bare.v_var_x.clear();
  bare.v_var_y.clear();
  const FusionResult bare_result = fuse({kBox}, bare.view(), FusionConfig{});
  const FusedObject& b = bare_result.objects.at(0);
  EXPECT_NEAR(b.grid.dynamic_share, 0.2, 1e-12);
  EXPECT_FALSE(b.grid.has_velocity);
  EXPECT_DOUBLE_EQ(gridEvidence(bare.view(), {}).dynamic_share, 0.5);
}

TEST(CheckFusionInputs, AcceptsGoodAndNamesTheFault)
{
  EXPECT_EQ(checkFusionInputs({kBox}, 640, 480, 640, 480), "");
  EXPECT_EQ(checkFusionInputs({}, 640, 480, 640, 480), "");
  EXPECT_NE(checkFusionInputs({kBox}, 640, 480, 1242, 375).find("image size mismatch"), std::string::npos);
  const std::string swapped =
      checkFusionInputs({makeDetection(200.F, 100.F, 100.F, 180.F)}, 640, 480, 640, 480);
  EXPECT_NE(swapped.find("x_min > x_max"), std::string::npos) << swapped;
  EXPECT_NE(swapped.find("detection 0"), std::string::npos) << swapped;
  const std::string outside =
      checkFusionInputs({kBox, makeDetection(600.F, 100.F, 700.F, 180.F)}, 640, 480, 640, 480);
  EXPECT_NE(outside.find("detection 1"), std::string::npos) << outside;
  EXPECT_NE(outside.find("outside"), std::string::npos) << outside;
  const std::string nan_box =
      checkFusionInputs({makeDetection(kNaN, 100.F, 200.F, 180.F)}, 640, 480, 640, 480);
  EXPECT_NE(nan_box.find("non-finite"), std::string::npos) << nan_box;
  // Half a pixel past the border is tolerated (detectors clip to the pixel grid).
  EXPECT_EQ(checkFusionInputs({makeDetection(0.F, 0.F, 640.5F, 480.F)}, 640, 480, 640, 480), "");
}

}  // namespace grid_vision_fusion
