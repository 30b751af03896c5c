// Unit tests of the object centre estimate on constructed cell sets: a car seen from behind,
// from the side and across a corner, a rotated car, an occluder in front, a wall behind, a class
// without a footprint; and of the outline orientation fit.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <stdexcept>

#include "grid_vision_fusion/fusion/fusion.h"
#include "grid_vision_fusion/fusion/object_centre.h"

namespace grid_vision_fusion
{
namespace
{
constexpr double kCell = 0.2;  // the grid's resolution [m]
// The box of the object: bottom edge at v = 300 px, 100 px high.
const BoundingBox kBox{100.F, 200.F, 300.F, 300.F};
const Footprint kCar{3.9, 1.6};

/// Cells every 0.2 m from (x0, y0) to (x1, y1) (both included), projected at row `v`.
void addFace(ProjectedPoints& points, double x0, double y0, double x1, double y1, float v = 300.F)
{
  const double length = std::hypot(x1 - x0, y1 - y0);
  const int steps = static_cast<int>(std::round(length / kCell));
  for (int i = 0; i <= steps; ++i)
  {
    const double f = steps > 0 ? static_cast<double>(i) / steps : 0.0;
    points.add(200.F, v, static_cast<float>(x0 + f * (x1 - x0)), static_cast<float>(y0 + f * (y1 - y0)), 0.F,
               0.F, CellState::kStatic);
  }
}

std::vector<std::uint32_t> all(const ProjectedPoints& points)
{
  std::vector<std::uint32_t> members(points.size());
  std::iota(members.begin(), members.end(), 0U);
  return members;
}
}  // namespace

TEST(ObjectCentre, CarSeenFromBehindIsCompletedAwayFromTheCamera)
{
  // Rear face at x = 10 from y = -0.8 to 0.8; camera at the origin looking along +x. The car
  // extends 3.9 m away from the camera: centre (10 + 1.95, 0).
  ProjectedPoints points;
  addFace(points, 10.0, -0.8, 10.0, 0.8);
  const CentreEstimate c = estimateCentre(points.view(), all(points), kBox, 0.0, 0.0, &kCar, CentreConfig{});
  EXPECT_NEAR(c.x, 11.95, 1e-6);
  EXPECT_NEAR(c.y, 0.0, 1e-6);
}

TEST(ObjectCentre, CarSeenFromTheSideTakesItsWidthAcross)
{
  // Near side at y = 5 from x = 8 to 11.8 (the whole 3.9 m less one cell is seen); camera at
  // (10, 0): the centre is midway along x (9.9) and half the width (0.8) beyond y = 5.
  ProjectedPoints points;
  addFace(points, 8.0, 5.0, 11.8, 5.0);
  const CentreEstimate c = estimateCentre(points.view(), all(points), kBox, 10.0, 0.0, &kCar, CentreConfig{});
  EXPECT_NEAR(c.x, 9.9, 1e-6);
  EXPECT_NEAR(c.y, 5.8, 1e-6);
}

TEST(ObjectCentre, CornerViewCompletesBothAxes)
{
  // Rear face x = 10, y in [2, 3.6]; near side y = 2, x in [10, 13.8]: an L seen from the
  // origin. Centre: the rear face is 1.6 m wide (fully seen) -> midway 2.8; the side is 3.8 m
  // of 3.9 seen: the camera is before the rear face, so x = 10 + 3.9 / 2 = 11.95.
  ProjectedPoints points;
  addFace(points, 10.0, 2.0, 10.0, 3.6);
  addFace(points, 10.2, 2.0, 13.8, 2.0);
  const CentreEstimate c = estimateCentre(points.view(), all(points), kBox, 0.0, 0.0, &kCar, CentreConfig{});
  EXPECT_NEAR(c.x, 11.95, 1e-6);
  EXPECT_NEAR(c.y, 2.8, 1e-6);
  EXPECT_NEAR(c.yaw, 0.0, 1e-9);
}

TEST(ObjectCentre, RotatedCarOrientationAndCentre)
{
  // A car at yaw 30° with its centre at (15, 4); the faces seen from the origin are the rear
  // (at −1.95 m along the heading) and the right side (at −0.8 m across it).
  const double yaw = M_PI / 6.0;
  const double hx = std::cos(yaw), hy = std::sin(yaw);  // heading
  const double lx = -hy, ly = hx;                       // left
  auto corner = [&](double along, double across)
  { return std::make_pair(15.0 + along * hx + across * lx, 4.0 + along * hy + across * ly); };
  ProjectedPoints points;
  const auto rear_right = corner(-1.95, -0.8);
  const auto rear_left = corner(-1.95, 0.8);
  const auto front_right = corner(1.95, -0.8);
  addFace(points, rear_right.first, rear_right.second, rear_left.first, rear_left.second);
  addFace(points, rear_right.first, rear_right.second, front_right.first, front_right.second);
  const CentreEstimate c = estimateCentre(points.view(), all(points), kBox, 0.0, 0.0, &kCar, CentreConfig{});
  EXPECT_NEAR(c.yaw, yaw, 1.5 * M_PI / 180.0);
  EXPECT_NEAR(c.x, 15.0, 0.15);
  EXPECT_NEAR(c.y, 4.0, 0.15);
  // The paper's median of the same cells lies on the visible faces, well away from the centre.
  FusionResult result = fuse({Detection{0, "car", 0.9F, BoundingBox{100.F, 200.F, 300.F, 300.F}}},
                             points.view(), FusionConfig{});
  ASSERT_EQ(result.objects.size(), 1U);
  EXPECT_GT(std::hypot(result.objects[0].median_x - 15.0, result.objects[0].median_y - 4.0), 0.7);
  estimateCentres(result, {Detection{0, "car", 0.9F, kBox}}, points.view(), 0.0, 0.0, CentreConfig{});
  EXPECT_NEAR(result.objects[0].centre_x, c.x, 1e-9);
  EXPECT_NEAR(result.objects[0].centre_y, c.y, 1e-9);
}

TEST(ObjectCentre, CellsBelowTheBottomEdgeBelongToAnObjectInFront)
{
  // The object (a truck's rear at x = 30, 3 cells at the bottom edge row 300) behind a van
  // whose 12 cells at x = 22 project 25 px below the bottom edge (25 % of the box height): each
  // van cell weighs exp(−((25 − 10)/10)²) = 0.11, 12 of them 1.3 against the truck's 3: the van
  // is in front, the truck's cells are taken.
  ProjectedPoints points;
  addFace(points, 22.0, -1.0, 22.0, 1.2, 325.F);
  addFace(points, 30.0, -0.2, 30.0, 0.2, 300.F);
  const Footprint truck{10.1, 2.6};
  const CentreEstimate c = estimateCentre(points.view(), all(points), kBox, 0.0, 0.0, &truck, CentreConfig{});
  EXPECT_NEAR(c.x, 30.0 + 10.1 / 2.0, 1e-6) << "the truck's cells, completed by its footprint";
  // Cells just below the edge (within 10 % of h: a trained detector's bottom edge errs by that
  // much) still count fully: the van wins at row 308.
  ProjectedPoints near_edge;
  addFace(near_edge, 22.0, -1.0, 22.0, 1.2, 308.F);
  addFace(near_edge, 30.0, -0.2, 30.0, 0.2, 300.F);
  EXPECT_NEAR(estimateCentre(near_edge.view(), all(near_edge), kBox, 0.0, 0.0, &truck, CentreConfig{}).x,
              22.0 + 10.1 / 2.0, 1e-6)
      << "the van's cells, completed by the footprint";
}

TEST(ObjectCentre, CellsHighAboveTheBottomEdgeBelongToWhatStandsBehind)
{
  // A pedestrian (3 cells at x = 10, bottom edge row 300) before a wall 3 m behind whose 12
  // cells project 25 px higher (25 % of the box height): each wall cell weighs
  // exp(−((25 − 10)/10)²) = 0.11, 12 of them 1.3 against the pedestrian's 3.
  ProjectedPoints points;
  addFace(points, 13.0, -1.0, 13.0, 1.2, 275.F);
  addFace(points, 10.0, -0.2, 10.0, 0.2, 300.F);
  const std::vector<std::uint32_t> cluster = objectCluster(points.view(), all(points), kBox, 0.5);
  EXPECT_EQ(cluster, (std::vector<std::uint32_t>{12, 13, 14}));
  // At row 291 each wall cell counts fully (within 10 % of h), but the wall's nearest cell lies
  // 9 px = 1.9 σ of a trained detector's bottom-edge error (4.7 % of h) above the edge:
  // 12 · exp(−1.9²/2) = 1.9 against the pedestrian's 3 (ego_curve_left: a house wall 1.4 m
  // behind a pedestrian at 20 m, 6 px higher in a 70 px box, took its cluster).
  ProjectedPoints behind;
  addFace(behind, 13.0, -1.0, 13.0, 1.2, 291.F);
  addFace(behind, 10.0, -0.2, 10.0, 0.2, 300.F);
  EXPECT_EQ(objectCluster(behind.view(), all(behind), kBox, 0.5), (std::vector<std::uint32_t>{12, 13, 14}));
  // Within the edge's error (row 297: 12 · exp(−(3 / 4.7)²/2) = 9.8) the wall wins by number.
  ProjectedPoints close;
  addFace(close, 13.0, -1.0, 13.0, 1.2, 297.F);
  addFace(close, 10.0, -0.2, 10.0, 0.2, 300.F);
  EXPECT_EQ(objectCluster(close.view(), all(close), kBox, 0.5).size(), 12U);
  EXPECT_TRUE(objectCluster(close.view(), {}, kBox, 0.5).empty());
}

TEST(ObjectCentre, TheCellsTheTrackExpectsContinue)
{
  // A wall behind a pedestrian, its 5 cells at row 297 (3 px above the bottom edge, within a
  // trained detector's edge error), outscores the pedestrian's 3 cells by the image alone:
  // 5 · 0.815 = 4.1. The pedestrian's track expects its 3 cells: its score doubles, 6 against 4.1.
  ProjectedPoints points;
  addFace(points, 13.0, -0.4, 13.0, 0.4, 297.F);  // the wall: 5 cells
  addFace(points, 10.0, -0.2, 10.0, 0.2, 300.F);  // the pedestrian: 3 cells
  EXPECT_EQ(objectCluster(points.view(), all(points), kBox, 0.5).size(), 5U) << "the image alone: the wall";
  const std::vector<Eigen::Vector2d> expected = {{10.1, -0.2}, {10.1, 0.0}, {10.1, 0.2}};
  EXPECT_EQ(objectCluster(points.view(), all(points), kBox, 0.5, expected),
            (std::vector<std::uint32_t>{5, 6, 7}))
      << "the track's cells continue: the pedestrian";
  // Expected cells far from every cluster change nothing.
  EXPECT_EQ(objectCluster(points.view(), all(points), kBox, 0.5, {{20.0, 5.0}}).size(), 5U);
}

TEST(ObjectCentre, WithoutAFootprintTheCentreOfTheCells)
{
  ProjectedPoints points;
  addFace(points, 10.0, -0.8, 10.0, 0.8);
  const CentreEstimate c =
      estimateCentre(points.view(), all(points), kBox, 0.0, 0.0, nullptr, CentreConfig{});
  EXPECT_NEAR(c.x, 10.0, 1e-6);
  EXPECT_NEAR(c.y, 0.0, 1e-6);
  // estimateCentres() looks the footprint up by label: "tram" has one, "robot" has none.
  FusionResult result = fuse({Detection{0, "robot", 0.9F, kBox}}, points.view(), FusionConfig{});
  estimateCentres(result, {Detection{0, "robot", 0.9F, kBox}}, points.view(), 0.0, 0.0, CentreConfig{});
  EXPECT_NEAR(result.objects.at(0).centre_x, 10.0, 1e-6);
}

TEST(ObjectCentre, ObservedExtentLargerThanTheFootprintIsKept)
{
  // A 12 m bus labelled truck (footprint 10.1 m) seen from the side: the cells span 12 m, their
  // middle is the centre along the bus.
  ProjectedPoints points;
  addFace(points, 4.0, 6.0, 16.0, 6.0);
  const Footprint truck{10.1, 2.6};
  const CentreEstimate c =
      estimateCentre(points.view(), all(points), kBox, 10.0, 0.0, &truck, CentreConfig{});
  EXPECT_NEAR(c.x, 10.0, 1e-6);
  EXPECT_NEAR(c.y, 6.0 + 1.3, 1e-6);
}

TEST(ObjectCentre, ATrailOfCellsTheLidarNoLongerHitsIsLeftOut)
{
  // A car creeping along +x, its near side at y = 5 seen from (10, 0): this scan hit its side
  // from x = 9 to 12.8 (the car spans 9 to 12.9, centre 10.95); the cells it left from x = 7.8
  // to 8.8 were last hit 8 scans ago and stay occupied (the lidar does not see them: the next
  // car of the queue hides them). All cells span 5 m, more than the car: their middle (10.3)
  // lies 0.65 m behind it. The fresh cells alone give 10.9.
  ProjectedPoints points;
  addFace(points, 7.8, 5.0, 8.8, 5.0);
  const std::size_t trail = points.size();
  addFace(points, 9.0, 5.0, 12.8, 5.0);
  std::vector<std::uint8_t> ages(points.size(), 0);
  std::fill(ages.begin(), ages.begin() + static_cast<std::ptrdiff_t>(trail), 8);
  ProjectedPointsView view = points.view();
  const auto centreX = [&](const ProjectedPointsView& v, int max_scans_since_hit)
  { return centreOfCluster(v, all(points), 10.0, 0.0, &kCar, max_scans_since_hit).x; };
  EXPECT_NEAR(centreX(view, 0), 10.3, 1e-6) << "no ages given: every cell";
  view.scans_since_hit = ages.data();
  EXPECT_NEAR(centreX(view, 0), 10.9, 1e-6);
  EXPECT_NEAR(centreX(view, 7), 10.9, 1e-6);
  EXPECT_NEAR(centreX(view, 8), 10.3, 1e-6) << "the trail is recent enough";
  EXPECT_NEAR(centreX(view, -1), 10.3, 1e-6) << "-1: every cell";
  CentreConfig config;
  EXPECT_EQ(config.max_scans_since_hit, 0);
  EXPECT_NEAR(estimateCentre(view, all(points), kBox, 10.0, 0.0, &kCar, config).x, 10.9, 1e-6);

  // A parked car whose cells fit its footprint keeps them all, the ones the lidar no longer
  // sees (hidden now) included: they are where the car is.
  ProjectedPoints parked;
  addFace(parked, 9.0, 5.0, 12.8, 5.0);
  std::vector<std::uint8_t> parked_ages(parked.size(), 0);
  std::fill(parked_ages.begin(), parked_ages.begin() + 6, 20);
  ProjectedPointsView parked_view = parked.view();
  parked_view.scans_since_hit = parked_ages.data();
  EXPECT_NEAR(centreOfCluster(parked_view, all(parked), 10.0, 0.0, &kCar, 0).x, 10.9, 1e-6);
  // Fewer than kMinFreshCentreCells fresh cells: all of them.
  std::fill(ages.begin(), ages.end(), 8);
  std::fill(ages.end() - 2, ages.end(), 0);
  EXPECT_NEAR(centreX(view, 0), 10.3, 1e-6);
}

TEST(ObjectCentre, OrientationOfARotatedOutline)
{
  for (const double deg : {0.0, 10.0, 37.0, 80.0})
  {
    const double t = deg * M_PI / 180.0;
    std::vector<double> x, y;
    for (int i = 0; i <= 20; ++i)  // an L: 4 m along t, 1.6 m across
    {
      x.push_back(0.2 * i * std::cos(t));
      y.push_back(0.2 * i * std::sin(t));
    }
    for (int i = 1; i <= 8; ++i)
    {
      x.push_back(-0.2 * i * std::sin(t));
      y.push_back(0.2 * i * std::cos(t));
    }
    EXPECT_NEAR(fitOrientation(x, y), t, 1.01 * M_PI / 180.0) << deg << " deg";
  }
  EXPECT_EQ(fitOrientation({1.0, 2.0}, {1.0, 2.0}), 0.0);
}

TEST(ObjectCentre, ConfigAndInputChecks)
{
  CentreConfig config;
  EXPECT_NO_THROW(config.validate());
  config.cluster_distance = 0.0;
  EXPECT_THROW(config.validate(), std::invalid_argument);
  config = CentreConfig{};
  config.footprints["car"] = Footprint{-1.0, 1.6};
  EXPECT_THROW(config.validate(), std::invalid_argument);
  config = CentreConfig{};
  config.footprints[""] = Footprint{1.0, 1.0};
  EXPECT_THROW(config.validate(), std::invalid_argument);
  for (const int bad : {-2, 255})
  {
    config = CentreConfig{};
    config.max_scans_since_hit = bad;
    EXPECT_THROW(config.validate(), std::invalid_argument) << bad;
  }
  FusionConfig fusion;
  fusion.centre.cluster_distance = std::nan("");
  EXPECT_THROW(fusion.validate(), std::invalid_argument);

  ProjectedPoints points;
  addFace(points, 10.0, 0.0, 10.0, 0.0);
  EXPECT_THROW(estimateCentre(points.view(), {}, kBox, 0.0, 0.0, &kCar, CentreConfig{}),
               std::invalid_argument);
  EXPECT_THROW(estimateCentre(points.view(), {5}, kBox, 0.0, 0.0, &kCar, CentreConfig{}),
               std::invalid_argument);
  EXPECT_EQ(positionSourceFromString("centre"), PositionSource::kCentre);
  EXPECT_EQ(positionSourceFromString("median"), PositionSource::kMedian);
  EXPECT_EQ(toString(PositionSource::kMedian), "median");
  EXPECT_THROW(positionSourceFromString("center"), std::invalid_argument);
}

}  // namespace grid_vision_fusion
