// Unit tests of the tracker on constructed sequences: track birth and confirmation (every object
// reported from its first image), crossing objects, an occluded object reappearing, a parked car
// passed at speed, a car that starts, the filter's velocity, boxes cut by the image edge, label
// gating and resets. The motion model itself: test_motion_model.cpp.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <utility>
#include <vector>

#include "grid_vision_fusion/fusion/object_tracking.h"
#include "grid_vision_fusion/fusion/tracker.h"

namespace grid_vision_fusion
{
namespace
{
constexpr double kFramePeriodS = 0.1;  // 10 Hz, as KITTI

/// What the grid says of a standing object: its cells static, their particles scattered.
GridMotionEvidence standingCells()
{
  GridMotionEvidence grid;
  grid.dynamic_share = 0.1;
  grid.has_velocity = true;
  grid.velocity_variance = Eigen::Vector2d(25.0, 25.0);
  return grid;
}

/// What the grid says of an object moving at (vx, vy): its cells dynamic, agreeing on it.
GridMotionEvidence movingCells(double vx, double vy)
{
  GridMotionEvidence grid;
  grid.dynamic_share = 0.9;
  grid.has_velocity = true;
  grid.velocity = Eigen::Vector2d(vx, vy);
  grid.velocity_variance = Eigen::Vector2d(1.0, 1.0);
  return grid;
}

/// An observation of a `label` at (x, y) with a box of 40 px around column u, standing cells.
TrackObservation observe(const std::string& label, double x, double y, float u)
{
  TrackObservation o;
  o.label = label;
  o.x = x;
  o.y = y;
  o.box = BoundingBox{u - 20.F, 100.F, u + 20.F, 180.F};
  o.grid = standingCells();
  return o;
}

/// `o` with its box cut by the image's left edge: an object `length` [m] long (a car's footprint).
TrackObservation cutByTheLeftEdge(TrackObservation o, double length = 3.9)
{
  o.box.x_min = 0.F;
  o.truncated = true;
  o.length = length;
  return o;
}

/// An observation moving at (vx, vy), the grid agreeing.
TrackObservation moving(const std::string& label, double x, double y, float u, double vx, double vy)
{
  TrackObservation o = observe(label, x, y, u);
  o.grid = movingCells(vx, vy);
  return o;
}

/// Grid cells projected into an image, as trackObjects() reads them: at (x, y) [m], all static,
/// `since_hit` scans since the lidar last hit each.
struct ProjectedCells
{
  std::vector<float> x, y;
  std::vector<std::uint8_t> since_hit;

  void add(double px, double py, std::uint8_t scans_since_hit = 0)
  {
    x.push_back(static_cast<float>(px));
    y.push_back(static_cast<float>(py));
    since_hit.push_back(scans_since_hit);
  }
  /// The view of the cells on a lattice of step `resolution` [m] (0: not given).
  ProjectedPointsView view(double resolution)
  {
    zeros.assign(x.size(), 0.F);
    states.assign(x.size(), static_cast<std::uint8_t>(CellState::kStatic));
    ProjectedPointsView points;
    points.size = x.size();
    points.u = points.v = points.vx = points.vy = zeros.data();
    points.x = x.data();
    points.y = y.data();
    points.state = states.data();
    points.scans_since_hit = since_hit.data();
    points.resolution = resolution;
    return points;
  }

private:
  std::vector<float> zeros;
  std::vector<std::uint8_t> states;
};

/// The lidar's hits on a car [m] whose rear face (9 cells across y from y = 2.1) stands at x0,
/// its side (10 cells along x) at y = 2.1: the cells of a 0.2 m grid.
std::vector<Eigen::Vector2d> carHits(double x0)
{
  std::vector<Eigen::Vector2d> hits;
  for (int j = 0; j < 9; ++j)  // the rear face
  {
    hits.emplace_back(x0, 2.1 + 0.2 * j);
  }
  for (int i = 1; i <= 10; ++i)  // the side
  {
    hits.emplace_back(x0 + 0.2 * i, 2.1);
  }
  return hits;
}

/// One detection of a car, its box at columns 500-700.
std::vector<Detection> carDetection()
{
  std::vector<Detection> detections(1);
  detections[0].label = "car";
  detections[0].box = BoundingBox{500.F, 150.F, 700.F, 250.F};
  return detections;
}
}  // namespace

TEST(Tracker, EveryObjectIsReportedFromItsFirstImageAndConfirmedAfterMinHits)
{
  Tracker tracker;  // min_hits 2
  const auto first = tracker.update(0.0, {observe("car", 10.0, 0.0, 300.F)});
  ASSERT_EQ(first.size(), 1U);
  EXPECT_FALSE(first[0].confirmed);
  EXPECT_EQ(first[0].id, 1U);
  EXPECT_EQ(first[0].motion, Motion::kStatic) << "the grid's static cells decide a new track";
  EXPECT_LT(first[0].p_dynamic, 0.5);
  for (int k = 1; k < 10; ++k)
  {
    const auto e = tracker.update(k * kFramePeriodS, {observe("car", 10.0, 0.0, 300.F)});
    ASSERT_EQ(e.size(), 1U);
    EXPECT_TRUE(e[0].confirmed);
    EXPECT_EQ(e[0].id, 1U);
    EXPECT_EQ(e[0].motion, Motion::kStatic);
  }
  // A tentative track survives max_misses images without an object, as a confirmed one: the car
  // at 30 m found again after two misses keeps its track (id 2), confirmed by its second hit; a
  // track missed more often is dropped.
  tracker.update(1.0, {observe("car", 10.0, 0.0, 300.F), observe("car", 30.0, 5.0, 600.F)});
  tracker.update(1.1, {observe("car", 10.0, 0.0, 300.F)});
  EXPECT_EQ(tracker.size(), 2U);
  tracker.update(1.2, {observe("car", 10.0, 0.0, 300.F)});
  const auto again =
      tracker.update(1.3, {observe("car", 10.0, 0.0, 300.F), observe("car", 30.0, 5.0, 600.F)});
  ASSERT_EQ(again.size(), 2U);
  EXPECT_EQ(again[1].id, 2U);
  EXPECT_TRUE(again[1].confirmed);
  for (int k = 4; k <= 4 + TrackerConfig{}.max_misses; ++k)
  {
    tracker.update(1.0 + k * kFramePeriodS, {observe("car", 10.0, 0.0, 300.F)});
  }
  EXPECT_EQ(tracker.size(), 1U) << "dropped after more than max_misses misses";
}

TEST(Tracker, ANewMoverIsDynamicFromItsFirstImageWhenTheGridSeesIt)
{
  Tracker tracker;
  const TrackEstimate e = tracker.update(0.0, {moving("cyclist", 15.0, 2.0, 500.F, 5.0, 0.0)})[0];
  EXPECT_FALSE(e.confirmed);
  EXPECT_EQ(e.motion, Motion::kDynamic);
  EXPECT_GT(e.p_dynamic, 0.9);
  EXPECT_NEAR(e.vx, 5.0, 1.0) << "the grid's velocity starts the constant-velocity model";
}

TEST(Tracker, AnObjectWithoutEvidenceIsUnknown)
{
  TrackObservation o = observe("car", 10.0, 0.0, 300.F);
  o.grid = GridMotionEvidence{};  // no cells: share 0.5, no velocity
  Tracker tracker;
  const TrackEstimate e = tracker.update(0.0, {o})[0];
  EXPECT_DOUBLE_EQ(e.p_dynamic, 0.5);
  EXPECT_EQ(e.motion, Motion::kUnknown);
}

TEST(Tracker, TheGridsWordCountsForItsImageOnly)
{
  // Two trackers see the same standing object; in image 3 the grid of one of them says
  // "dynamic" (its share only: no velocity that would move the filter). That image's P(dynamic)
  // differs; in image 4 the object's box has no cells in both (no new word of the grid), and the
  // two agree exactly: the evidence of image 3 is not carried on.
  Tracker plain;
  Tracker told;
  TrackObservation neutral = observe("car", 10.0, 0.0, 300.F);
  neutral.grid = GridMotionEvidence{};  // share 0.5: no word
  TrackObservation dynamic_share = neutral;
  dynamic_share.grid.dynamic_share = 0.95;
  TrackObservation without_cells = neutral;
  without_cells.supported = false;
  std::vector<double> p_plain;
  std::vector<double> p_told;
  for (int k = 0; k < 5; ++k)
  {
    const TrackObservation& same = k == 4 ? without_cells : neutral;
    p_plain.push_back(plain.update(k * kFramePeriodS, {same})[0].p_dynamic);
    p_told.push_back(told.update(k * kFramePeriodS, {k == 3 ? dynamic_share : same})[0].p_dynamic);
  }
  EXPECT_GT(p_told[3], p_plain[3] + 0.1);
  EXPECT_DOUBLE_EQ(p_told[4], p_plain[4]);
}

TEST(Tracker, CrossingPedestriansKeepTheirIds)
{
  // Two pedestrians cross each other 0.8 m apart in depth at 1.5 m/s in opposite directions;
  // their boxes overlap in the image while they pass (same column at t = 2 s).
  Tracker tracker;
  std::uint32_t id_a = 0, id_b = 0;
  for (int k = 0; k <= 40; ++k)
  {
    const double t = k * kFramePeriodS;
    const double ya = -3.0 + 1.5 * t;
    const double yb = 3.0 - 1.5 * t;
    const auto e =
        tracker.update(t, {moving("pedestrian", 10.0, ya, static_cast<float>(400.0 - 60.0 * ya), 0.0, 1.5),
                           moving("pedestrian", 10.8, yb, static_cast<float>(400.0 - 55.0 * yb), 0.0, -1.5)});
    ASSERT_EQ(e.size(), 2U);
    if (k == 0)
    {
      id_a = e[0].id;
      id_b = e[1].id;
      EXPECT_NE(id_a, id_b);
    }
    EXPECT_EQ(e[0].id, id_a) << "t = " << t;
    EXPECT_EQ(e[1].id, id_b) << "t = " << t;
    EXPECT_EQ(e[0].motion, Motion::kDynamic) << "t = " << t;
    EXPECT_EQ(e[1].motion, Motion::kDynamic) << "t = " << t;
  }
  EXPECT_NEAR(tracker.update(4.1, {moving("pedestrian", 10.0, 3.15, 211.F, 0.0, 1.5)})[0].vy, 1.5, 0.2);
}

TEST(Tracker, AnOccludedObjectReappearingGetsItsIdBack)
{
  // A car at 8 m/s seen for 1 s, hidden for 0.4 s (4 images, max_misses 5), seen again where
  // it drove to: same id. Hidden for 0.7 s (7 images): a new id.
  for (const int hidden : {4, 7})
  {
    Tracker tracker;
    std::uint32_t id = 0;
    int k = 0;
    for (; k <= 10; ++k)
    {
      id = tracker.update(k * kFramePeriodS, {moving("car", 5.0 + 0.8 * k, 2.0, 500.F, 8.0, 0.0)})[0].id;
    }
    for (int h = 0; h < hidden; ++h, ++k)
    {
      tracker.update(k * kFramePeriodS, {});
    }
    const auto e = tracker.update(k * kFramePeriodS, {moving("car", 5.0 + 0.8 * k, 2.0, 700.F, 8.0, 0.0)});
    if (hidden <= TrackerConfig{}.max_misses)
    {
      EXPECT_EQ(e[0].id, id) << hidden << " images hidden";
      EXPECT_TRUE(e[0].confirmed);
    }
    else
    {
      EXPECT_NE(e[0].id, id) << hidden << " images hidden";
      EXPECT_FALSE(e[0].confirmed);
    }
  }
}

TEST(Tracker, AParkedCarPassedAtSpeedNeverFlickersDynamic)
{
  // The ego passes a parked car: its centre estimate wanders as the visible faces change (up to
  // ±0.4 m), or wanders less (±0.25 m) while every fifth image half of its cells turn dynamic
  // with a spurious velocity (motion smear of the grid). The verdict stays static throughout.
  for (const bool smear : {false, true})
  {
    Tracker tracker;
    const double amplitude = smear ? 0.25 : 0.4;
    for (int k = 0; k < 60; ++k)
    {
      const double wobble = amplitude * std::sin(0.7 * k);
      TrackObservation o =
          observe("car", 20.0 + wobble, -5.0 - 0.5 * wobble, static_cast<float>(100 + 15 * k));
      if (smear && k % 5 == 4)
      {
        o.grid.dynamic_share = 0.5;
        o.grid.velocity = Eigen::Vector2d(-3.0, 0.0);
        o.grid.velocity_variance = Eigen::Vector2d(4.0, 4.0);
      }
      const auto e = tracker.update(k * kFramePeriodS, {o});
      EXPECT_EQ(e[0].motion, Motion::kStatic) << "image " << k << (smear ? " with smear" : "");
      EXPECT_EQ(e[0].id, 1U);
    }
  }
}

TEST(Tracker, ACarThatStartsIsDynamicWithinAFewImages)
{
  // Parked for 3 s, then it drives off at 3 m/s and its cells turn dynamic: dynamic within
  // 0.3 s (3 images), with the velocity of the grid and of its displacement.
  Tracker tracker;
  int k = 0;
  for (; k < 30; ++k)
  {
    EXPECT_EQ(tracker.update(k * kFramePeriodS, {observe("car", 12.0, 3.0, 400.F)})[0].motion,
              Motion::kStatic);
  }
  const int start = k;
  int first_dynamic = -1;
  TrackEstimate e;
  for (double x = 12.0; k < start + 20; ++k)
  {
    x += 0.3;
    e = tracker.update(k * kFramePeriodS, {moving("car", x, 3.0, 400.F, 3.0, 0.0)})[0];
    if (first_dynamic < 0 && e.motion == Motion::kDynamic)
    {
      first_dynamic = k - start;
    }
  }
  EXPECT_GE(first_dynamic, 0);
  EXPECT_LE(first_dynamic, 2);
  EXPECT_EQ(e.motion, Motion::kDynamic);
  EXPECT_NEAR(e.vx, 3.0, 0.3);
}

TEST(Tracker, AWalkingPedestrianIsDynamicSoonerUnderAPedestriansPriorSpeed)
{
  // A pedestrian walking at 1.4 m/s from its first image (0.14 m per image, less than a grid
  // cell; its centre ±0.1 m across the walk from image to image), its cells a quarter dynamic
  // and their velocity unknown (as the grid sees a walking pedestrian: pedestrians_along, shares
  // 0.17 to 0.33). Under a vehicle's prior speed of 3 m/s per axis the constant-velocity model
  // pays for the speeds it could have had, and the first steps favour standing; under a
  // pedestrian's 1.5 m/s it is dynamic sooner.
  auto first_dynamic = [](const TrackerConfig& config)
  {
    Tracker tracker(config);
    for (int k = 0; k < 30; ++k)
    {
      TrackObservation o = observe("pedestrian", 10.0 + 0.14 * k, 2.0 + ((k % 2) ? 0.1 : -0.1), 400.F);
      o.grid = GridMotionEvidence{};
      o.grid.dynamic_share = 0.25;
      if (tracker.update(k * kFramePeriodS, {o})[0].motion == Motion::kDynamic)
      {
        return k;
      }
    }
    return -1;
  };
  TrackerConfig walking;  // the default: pedestrian 1.5 m/s
  TrackerConfig vehicle;
  vehicle.class_speed_sigmas.clear();
  const int with_prior = first_dynamic(walking);
  const int without = first_dynamic(vehicle);
  ASSERT_GE(with_prior, 0);
  ASSERT_GE(without, 0);
  EXPECT_LT(with_prior, without);  // 4 images against 5
  EXPECT_LE(with_prior, 4);
}

TEST(Tracker, TheFilterFindsTheVelocityFromPositionsAlone)
{
  // No grid evidence: positions only, a car at (6, −2) m/s. After 3 s the constant-velocity
  // model's velocity is within 0.2 m/s and the verdict dynamic.
  Tracker tracker;
  TrackEstimate e;
  for (int k = 0; k <= 30; ++k)
  {
    const double t = k * kFramePeriodS;
    TrackObservation o = observe("car", 10.0 + 6.0 * t, 4.0 - 2.0 * t, 500.F);
    o.grid = GridMotionEvidence{};
    e = tracker.update(t, {o})[0];
  }
  EXPECT_NEAR(e.vx, 6.0, 0.2);
  EXPECT_NEAR(e.vy, -2.0, 0.2);
  EXPECT_EQ(e.motion, Motion::kDynamic);
  EXPECT_GT(e.p_dynamic, 0.99);
}

TEST(Tracker, AParkedCarLeavingTheImageIsNotTakenForAMover)
{
  // The ego passes a parked car (length along x) that leaves the image at its left edge: the
  // box is cut and the centre of the visible part slides 2.7 m forward over 12 images while the
  // cells miss more and more of the car's length. Measured as a centre, that would read as
  // 2.2 m/s; a cut box's centre is off by up to half the car's length, and the car stays static.
  Tracker tracker;
  int k = 0;
  for (; k < 20; ++k)
  {
    tracker.update(k * kFramePeriodS, {observe("car", 8.0, 4.0, 300.F)});
  }
  for (int j = 1; j <= 12; ++j, ++k)
  {
    const double visible = 8.0 + 0.225 * j;
    const TrackObservation o = cutByTheLeftEdge(observe("car", visible, 4.0, 30.F));
    const TrackEstimate e = tracker.update(k * kFramePeriodS, {o})[0];
    EXPECT_EQ(e.motion, Motion::kStatic) << "image " << j << " of the cut box";
    EXPECT_LT(e.p_dynamic, 0.45) << "image " << j;
    EXPECT_LT(e.x, visible) << "the estimate lags the visible part";
  }
}

TEST(Tracker, ACutBoxsCentreSaysLessWhileTheCameraSweepsAlongIt)
{
  // A car cut by the image's left edge creeps forward at 1.5 m/s, the grid saying nothing either
  // way (a queue's neighbour). With the camera standing, the window the image shows is fixed, and
  // the centres tell the motion; with the camera passing at 10 m/s they are off by up to half the
  // car's length, and say much less.
  auto run = [](double camera_speed)
  {
    Tracker tracker;
    TrackEstimate e;
    for (int k = 0; k < 15; ++k)
    {
      TrackObservation o = cutByTheLeftEdge(observe("car", 8.0 + 0.15 * k, 4.0, 30.F));
      o.grid = GridMotionEvidence();
      e = tracker.update(k * kFramePeriodS, {o}, {},
                         Eigen::Vector2d(camera_speed * k * kFramePeriodS, 0.0))[0];
    }
    return e.p_dynamic;
  };
  EXPECT_GT(run(0.0), 0.9);
  EXPECT_LT(run(10.0), 0.8);
}

TEST(Tracker, AFastCarIsMeasuredFromItsSecondImage)
{
  // A car first seen at 20 m/s moves 2 m between two images: beyond the gate of a track that
  // knows only its prior speed, so its second object is admitted by its box. That step is the
  // car's first, not a jump of an estimate: the filters take it, and the centres alone (the grid
  // saying nothing) make it dynamic from its third image. Restarted at each step instead, the
  // track would never learn its velocity.
  Tracker tracker;
  for (int k = 0; k < 8; ++k)
  {
    TrackObservation o = observe("car", 10.0 + 2.0 * k, 3.0, 300.F + 4.F * static_cast<float>(k));
    o.grid = GridMotionEvidence();
    const TrackEstimate e = tracker.update(k * kFramePeriodS, {o})[0];
    EXPECT_EQ(e.id, 1U);
    if (k >= 2)
    {
      EXPECT_EQ(e.motion, Motion::kDynamic) << "image " << k;
    }
    if (k >= 4)
    {
      EXPECT_NEAR(e.vx, 20.0, 2.0) << "image " << k;
    }
  }
}

TEST(Tracker, ACutBoxWhoseCentreJumpsRestartsTheFiltersInsteadOfMovingThem)
{
  // A truck crosses at 8 m/s (along -y) with its box cut by the image edge. At image 10 its
  // outline turns: the cut box's centre jumps 3.75 m across its length. Taken as a measurement,
  // that jump would give the truck a sideways velocity of about 5 m/s, which the next centres
  // contradict (they then fit standing better); beyond the gate it restarts the filters there,
  // as for a box that is not cut.
  Tracker tracker;
  for (int k = 0; k < 20; ++k)
  {
    const bool turned = k >= 10;
    TrackObservation o =
        moving("truck", turned ? 16.25 : 20.0, 15.0 - 0.8 * k + (turned ? 2.65 : 0.0), 1230.F, 0.0, -8.0);
    o.box.x_max = 1242.F;
    o.truncated = true;
    o.length = 10.1;
    const TrackEstimate e = tracker.update(k * kFramePeriodS, {o})[0];
    EXPECT_EQ(e.id, 1U);
    if (k >= 3)
    {
      EXPECT_EQ(e.motion, Motion::kDynamic) << "image " << k;
      EXPECT_LT(std::abs(e.vx), 1.0) << "image " << k << ": the jump is not a sideways velocity";
      EXPECT_NEAR(e.vy, -8.0, 1.5) << "image " << k;
    }
  }
}

TEST(Tracker, TrackObjectsMarksBoxesCutByTheImageEdge)
{
  // trackObjects() tells the tracker which boxes touch the left or right image edge: the cut one
  // keeps its track's position although its centre moved.
  FusionResult result;
  FusedObject object;
  object.detection_index = 0;
  object.centre_x = 10.0;
  object.centre_y = 2.0;
  object.grid = standingCells();
  object.length = 3.9;
  result.objects = {object};
  std::vector<Detection> detections(1);
  detections[0].label = "car";
  detections[0].box = BoundingBox{100.F, 150.F, 300.F, 250.F};
  Tracker tracker;
  for (int k = 0; k < 10; ++k)
  {
    FusionResult r = result;
    trackObjects(tracker, k * kFramePeriodS, detections, 1242, ProjectedPointsView{}, r);
  }
  FusionResult cut = result;
  cut.objects[0].centre_x = 11.5;  // the visible part's centre
  detections[0].box.x_min = 0.F;
  trackObjects(tracker, 1.0, detections, 1242, ProjectedPointsView{}, cut);
  ASSERT_EQ(cut.reports.size(), 1U);
  EXPECT_LT(cut.reports[0].x, 10.5);
  EXPECT_EQ(cut.reports[0].track_state, TrackState::kConfirmed);
  EXPECT_EQ(cut.reports[0].motion, Motion::kStatic);
  EXPECT_LT(cut.reports[0].p_dynamic, 0.5);
  EXPECT_DOUBLE_EQ(cut.objects[0].centre_x, 11.5) << "the fused object keeps its own centre";
  EXPECT_TRUE(cut.tracked);
}

TEST(Tracker, TrackObjectsRegistersTheHitsOfTheGridsScan)
{
  // A parked car that a passing truck uncovers: its side is revealed by 3 cells per image and
  // its centre slides 0.3 m per image with the visible part; the grid's cells say standing, less
  // strongly than the centres say moving. Its rear face is hit at the same cells in every scan,
  // which the registration of the cluster's hits sees once the projected grid gives its cell
  // size. Cells of the cluster the lidar last hit 4 scans ago (a trail moving with the centre)
  // are not hits and are not registered.
  auto run = [](double resolution)
  {
    Tracker tracker;
    const std::vector<Detection> detections = carDetection();
    double p_max = 0.0;
    for (int k = 0; k < 8; ++k)
    {
      ProjectedCells cells;
      for (int j = 0; j < 9; ++j)  // the rear face
      {
        cells.add(10.1, 2.1 + 0.2 * j);
      }
      for (int i = 1; i <= 2 + 3 * k; ++i)  // the side revealed so far
      {
        cells.add(10.1 + 0.2 * i, 2.1);
      }
      for (int i = 0; i < 25; ++i)  // the trail
      {
        cells.add(11.1 + 0.4 * k + 0.2 * (i % 5), 3.9 + 0.2 * (i / 5), 4);
      }
      const ProjectedPointsView points = cells.view(resolution);
      FusionResult result;
      FusedObject object;
      object.detection_index = 0;
      object.centre_x = 10.5 + 0.3 * k;
      object.centre_y = 2.9;
      object.grid = standingCells();
      for (std::uint32_t i = 0; i < points.size; ++i)
      {
        object.cluster.push_back(i);
      }
      result.objects = {object};
      trackObjects(tracker, k * kFramePeriodS, detections, 1242, points, result);
      if (k > 0)  // the first image has no registration
      {
        p_max = std::max(p_max, result.reports.at(0).p_dynamic);
      }
    }
    return p_max;
  };
  EXPECT_GT(run(0.0), 0.5) << "without the cell size, the drifting centre reads as motion";
  EXPECT_LT(run(0.2), 0.5);
}

TEST(Tracker, TheHitsOfABoxCutByTheImageEdgeSayNothingAlongItsLength)
{
  // The ego passes a parked bus whose box the image's left edge cuts: the cells of its side that
  // the fusion band holds are those the image still shows, a window that slides with the ego
  // (1 m per image) along the bus's texture-less side. They would move with the ego; a cut box
  // says nothing along the object's length, and the bus stays static.
  Tracker tracker;
  auto side = [](int from)
  {
    std::vector<Eigen::Vector2d> hits;
    for (int i = 0; i < 25; ++i)
    {
      hits.emplace_back(8.1 + 0.2 * (from + i), 4.1);
    }
    return hits;
  };
  int k = 0;
  for (; k < 10; ++k)
  {
    TrackObservation o = observe("car", 9.0, 4.5, 300.F);
    o.hits = side(0);
    o.cell_size = 0.2;
    tracker.update(k * kFramePeriodS, {o});
  }
  for (int j = 1; j <= 6; ++j, ++k)
  {
    TrackObservation o = cutByTheLeftEdge(observe("car", 9.0 + 0.5 * j, 4.5, 30.F), 12.0);
    o.hits = side(5 * j);
    o.cell_size = 0.2;
    const TrackEstimate e = tracker.update(k * kFramePeriodS, {o})[0];
    EXPECT_EQ(e.motion, Motion::kStatic) << "image " << j << " of the cut box";
  }
}

TEST(Tracker, ACutBoxSaysNothingOfItsMotionThatTheGridDoesNot)
{
  // A parked car beside the ego, cut by the image's left edge (KITTI drive 0009): the centre of
  // its visible part slides 0.6 m per image, its outline's axes swing, and the hits of the
  // window the image shows move with it. Neither says how the car moves; its cells do: static
  // cells keep it static, a mover's cells make it dynamic.
  auto run = [](const GridMotionEvidence& cells)
  {
    Tracker tracker;
    double p_max = 0.0;
    double p_min = 1.0;
    for (int k = 0; k < 6; ++k)
    {
      TrackObservation o = cutByTheLeftEdge(observe("car", 7.3 + 0.6 * k, 4.5, 30.F));
      for (int i = 0; i < 10; ++i)
      {
        o.hits.emplace_back(6.1 + 0.6 * k + 0.2 * i, 3.7);
      }
      o.cell_size = 0.2;
      o.grid = cells;
      const double p = tracker.update(k * kFramePeriodS, {o})[0].p_dynamic;
      p_max = std::max(p_max, p);
      p_min = std::min(p_min, p);
    }
    return std::make_pair(p_min, p_max);
  };
  EXPECT_LT(run(standingCells()).second, 0.5);
  EXPECT_GT(run(movingCells(6.0, 0.0)).first, 0.5);
}

TEST(Tracker, ABoxWithoutCellsKeepsItsTrackAndSaysItsMotionIsUnknown)
{
  // A parked car whose band holds no cell for three images (the lidar does not reach it): its
  // track keeps it, with its id and P(dynamic), at its predicted position; its box alone does not
  // move the motion model. A new box without cells has its box's position and nothing more.
  Tracker tracker;
  int k = 0;
  for (; k < 10; ++k)
  {
    tracker.update(k * kFramePeriodS, {observe("car", 20.0, 4.0, 300.F)});
  }
  for (int j = 0; j < 3; ++j, ++k)
  {
    TrackObservation o = observe("car", 26.0, 4.0, 302.F);  // the box's ground point: 6 m off
    o.supported = false;
    TrackObservation newcomer = observe("car", 40.0, -3.0, 800.F);
    newcomer.supported = false;
    const std::vector<TrackEstimate> e = tracker.update(k * kFramePeriodS, {o, newcomer});
    EXPECT_EQ(e[0].id, 1U);
    EXPECT_TRUE(e[0].located);
    EXPECT_NEAR(e[0].x, 20.0, 0.1) << "the track's prediction, not the box's ground point";
    EXPECT_LT(e[0].p_dynamic, 0.2);
    EXPECT_FALSE(e[1].located);
    EXPECT_EQ(e[1].id, 2U) << "kept from image to image by its box";
  }
  // Cells again: the track goes on from where it was.
  const TrackEstimate back = tracker.update(k * kFramePeriodS, {observe("car", 20.0, 4.0, 300.F)})[0];
  EXPECT_EQ(back.id, 1U);
  EXPECT_EQ(back.motion, Motion::kStatic);
  // The new one's first cells locate it: its motion model starts there.
  TrackObservation located = observe("car", 40.5, -3.0, 800.F);
  const std::vector<TrackEstimate> both =
      tracker.update((k + 1) * kFramePeriodS, {observe("car", 20.0, 4.0, 300.F), located});
  EXPECT_EQ(both[1].id, 2U);
  EXPECT_TRUE(both[1].located);
  EXPECT_NEAR(both[1].x, 40.5, 1e-9);
}

TEST(Tracker, ANewTrackRegistersItsFirstHitsAgainstTheScansBefore)
{
  // A car the detector misses for three images, then finds: the lidar hit its rear face and side
  // in every scan, at 4 m/s along x (two cells per scan), beside a standing wall. The grid says
  // nothing of it (no cells' evidence). Its first hits registered against those of the scans
  // before say how it moved from its first image; without the scans before there is no
  // evidence, and a standing car's hits say standing.
  auto first_image = [](double speed, bool scans_before)
  {
    Tracker tracker;
    for (int k = 0; k <= 3; ++k)
    {
      const double x0 = 10.1 + speed * kFramePeriodS * k;
      std::vector<Eigen::Vector2d> scene = carHits(x0);
      for (int i = 0; i < 60; ++i)  // the wall
      {
        scene.emplace_back(4.1 + 0.2 * i, -3.1);
      }
      std::vector<TrackObservation> observations;
      if (k == 3)
      {
        TrackObservation o = observe("car", x0 + 2.0, 2.9, 600.F);
        o.grid = GridMotionEvidence{};
        o.hits = carHits(x0);
        o.cell_size = 0.2;
        observations.push_back(o);
      }
      const auto estimates = tracker.update(k * kFramePeriodS, observations,
                                            scans_before ? scene : std::vector<Eigen::Vector2d>{});
      if (k == 3)
      {
        return estimates.at(0).p_dynamic;
      }
    }
    return -1.0;
  };
  EXPECT_GT(first_image(4.0, true), 0.8);
  EXPECT_DOUBLE_EQ(first_image(4.0, false), 0.5) << "without the scans before, nothing is known";
  EXPECT_LT(first_image(0.0, true), 0.2);
}

TEST(Tracker, ATrackSeenWithoutCellsFirstDoesNotRegisterAgainstTheScansBefore)
{
  // A parked car the camera sees for three images while the lidar does not (an occluder hides it
  // from the lidar): its boxes come without cells. The scans of those images hold the hits of the
  // next parked car, of the same shape, 2 m to its right, and none of its own. Its first hits,
  // registered against them, would say that this car came from there. It registers against its
  // own hits only: standing, as the grid says. A car first seen with its cells still registers
  // against the scans before (previous test).
  auto first_images = [](bool boxes_without_cells)
  {
    Tracker tracker;
    double p_max = 0.0;
    for (int k = 0; k <= 5; ++k)
    {
      std::vector<Eigen::Vector2d> scene;
      for (const Eigen::Vector2d& hit : carHits(10.1))  // the next car, standing
      {
        scene.emplace_back(hit.x(), hit.y() - 2.0);
      }
      TrackObservation o = observe("car", 11.1, 2.9, 600.F);
      o.cell_size = 0.2;
      o.supported = k >= 3;
      if (o.supported)
      {
        o.hits = carHits(10.1);
        scene.insert(scene.end(), o.hits.begin(), o.hits.end());
      }
      std::vector<TrackObservation> observations;
      if (o.supported || boxes_without_cells)
      {
        observations.push_back(o);
      }
      const auto estimates = tracker.update(k * kFramePeriodS, observations, scene);
      if (o.supported)
      {
        p_max = std::max(p_max, estimates.at(0).p_dynamic);
      }
    }
    return p_max;
  };
  EXPECT_LT(first_images(true), 0.5);
  EXPECT_GT(first_images(false), 0.5) << "first seen with its cells: the scans before saw its place empty, "
                                         "and the next car's hits register as where it came from";
}

TEST(Tracker, TrackObjectsKeepsTheScenesHitsForNewTracks)
{
  // The grid's cells that the lidar hit in each image, objects or not, are the scans a new track
  // registers its first hits against: a car hit at 4 m/s for three images before it is detected
  // is dynamic in its first. Without those images' cells nothing is known.
  auto first_image = [](bool cells_before)
  {
    Tracker tracker;
    const std::vector<Detection> detections = carDetection();
    for (int k = 0; k <= 3; ++k)
    {
      ProjectedCells cells;
      const double x0 = 10.1 + 0.4 * k;
      if (cells_before || k == 3)
      {
        for (const Eigen::Vector2d& hit : carHits(x0))
        {
          cells.add(hit.x(), hit.y());
        }
      }
      const ProjectedPointsView points = cells.view(0.2);
      FusionResult result;
      if (k == 3)
      {
        FusedObject object;
        object.centre_x = x0 + 2.0;
        object.centre_y = 2.9;
        object.grid = GridMotionEvidence{};
        for (std::uint32_t i = 0; i < points.size; ++i)
        {
          object.cluster.push_back(i);
        }
        result.objects = {object};
      }
      trackObjects(tracker, k * kFramePeriodS, detections, 1242, points, result);
      if (k == 3)
      {
        return result.reports.at(0).p_dynamic;
      }
    }
    return -1.0;
  };
  EXPECT_GT(first_image(true), 0.8);
  EXPECT_DOUBLE_EQ(first_image(false), 0.5);
}

TEST(Tracker, OnlyLabelsOfOneGroupAreAssociated)
{
  Tracker tracker;
  tracker.update(0.0, {observe("car", 10.0, 0.0, 300.F)});
  const auto e = tracker.update(0.1, {observe("pedestrian", 10.0, 0.0, 300.F)});
  EXPECT_EQ(e[0].id, 2U);
  EXPECT_FALSE(e[0].confirmed);
}

TEST(Tracker, AVanCalledCarNowAndThenStaysAVanOnItsTrack)
{
  // A detector sees a van as "van" (class 2) at 0.8, and in every third image as "car" (class 0)
  // at 0.6: one track, reported as a van throughout; an object of another group (a pedestrian)
  // at the same place starts its own track.
  Tracker tracker;  // the default groups car, van and truck
  for (int k = 0; k < 12; ++k)
  {
    TrackObservation o = observe(k % 3 == 2 ? "car" : "van", 15.0, 2.0, 400.F);
    o.score = k % 3 == 2 ? 0.6 : 0.8;
    o.class_id = k % 3 == 2 ? 0 : 2;
    const TrackEstimate e = tracker.update(k * kFramePeriodS, {o})[0];
    EXPECT_EQ(e.id, 1U) << "image " << k;
    EXPECT_EQ(e.label, "van") << "image " << k;
    EXPECT_EQ(e.class_id, 2U) << "image " << k;
  }
  TrackerConfig ungrouped;
  ungrouped.label_groups.clear();  // every label a group of its own
  Tracker strict(ungrouped);
  strict.update(0.0, {observe("van", 15.0, 2.0, 400.F)});
  EXPECT_EQ(strict.update(0.1, {observe("car", 15.0, 2.0, 400.F)})[0].id, 2U);
}

TEST(Tracker, ATrackExpectsItsCellsMovedOnByItsVelocity)
{
  // A car at 10 m/s along x, its cluster's cells given: in the next image its detection (the box
  // moved 10 px) expects those cells 1 m further; a pedestrian's box there expects nothing (another
  // group), nor a box that does not overlap, nor any box after a gap over max_gap.
  Tracker tracker;
  for (int k = 0; k < 10; ++k)
  {
    TrackObservation o = moving("car", 10.0 + k, 0.0, 300.F + 10.F * k, 10.0, 0.0);
    o.cells = {{8.0 + k, -0.8}, {8.0 + k, 0.8}};
    tracker.update(k * kFramePeriodS, {o});
  }
  std::vector<Detection> detections(3);
  detections[0].label = "car";
  detections[0].box = BoundingBox{380.F, 100.F, 420.F, 180.F};
  detections[1].label = "pedestrian";
  detections[1].box = detections[0].box;
  detections[2].label = "car";
  detections[2].box = BoundingBox{900.F, 100.F, 940.F, 180.F};
  const auto priors = tracker.priors(1.0, detections);
  ASSERT_EQ(priors.size(), 3U);
  ASSERT_EQ(priors[0].cells.size(), 2U);
  EXPECT_NEAR(priors[0].cells[0].x(), 18.0, 0.1);
  EXPECT_NEAR(priors[0].cells[1].y(), 0.8, 0.05);
  EXPECT_TRUE(priors[0].has_box);
  EXPECT_EQ(priors[0].label, "car");
  EXPECT_TRUE(priors[1].cells.empty());
  EXPECT_FALSE(priors[1].has_box);
  EXPECT_TRUE(priors[2].cells.empty());
  EXPECT_FALSE(priors[2].has_box);
  EXPECT_TRUE(tracker.priors(3.0, detections)[0].cells.empty()) << "a gap over max_gap";
}

TEST(Tracker, ATrackFiltersTheBoxItsNextDetectionIsFusedWith)
{
  // A box sliding right at 100 px/s whose bottom edge jitters by ±6 px from image to image (a
  // trained detector's): the box a track expects of the next detection follows the slide and
  // halves the jitter; with box_gain 1 it is the detector's box. The prior also carries the
  // track's label: a van called "car" in one image keeps the van's footprint.
  const auto box_at = [](int k)
  {
    const float u = 300.F + 10.F * static_cast<float>(k);
    return BoundingBox{u, 100.F, u + 60.F, 160.F + (k % 2 == 0 ? 6.F : -6.F)};
  };
  for (const double gain : {0.5, 1.0})
  {
    TrackerConfig config;
    config.box_gain = gain;
    Tracker tracker(config);
    double raw_spread = 0.0;
    double filtered_spread = 0.0;
    for (int k = 0; k < 30; ++k)
    {
      std::vector<Detection> detections(1);
      detections[0].label = k == 29 ? "car" : "van";
      detections[0].box = box_at(k);
      const auto priors = tracker.priors(k * kFramePeriodS, detections);
      ASSERT_EQ(priors.size(), 1U);
      EXPECT_EQ(priors[0].has_box, k > 0) << "image " << k;
      if (k >= 10)
      {
        EXPECT_NEAR(priors[0].box.x_min, detections[0].box.x_min, 0.5)
            << "no lag on a steady slide, image " << k;
        EXPECT_NEAR(priors[0].box.x_max, detections[0].box.x_max, 0.5) << "image " << k;
        raw_spread = std::max(raw_spread, std::abs(detections[0].box.y_max - 160.0));
        filtered_spread = std::max(filtered_spread, std::abs(priors[0].box.y_max - 160.0));
        EXPECT_EQ(priors[0].label, "van") << "image " << k;
      }
      TrackObservation o = observe(detections[0].label, 15.0, 2.0, 0.F);
      o.box = detections[0].box;
      tracker.update(k * kFramePeriodS, {o});
    }
    EXPECT_DOUBLE_EQ(raw_spread, 6.0);
    if (gain < 1.0)
    {
      EXPECT_LT(filtered_spread, 3.5) << "the jitter is damped";
    }
    else
    {
      EXPECT_DOUBLE_EQ(filtered_spread, 6.0) << "gain 1: the detector's box";
    }
  }
}

TEST(Tracker, ABoxFilterStartsWithItsTracksFirstCells)
{
  // A cyclist entering at the image's right edge: its first boxes hold no cell (a sliver, standing
  // still in the image), then the box opens up and the band finds its cells. Those first cells
  // are fused in the detector's box, not in one the boxes without cells lag behind, and from then
  // on the track's filter goes as a track born at its first cells would.
  const auto cyclist = [](float x_min)
  {
    std::vector<Detection> detections(1);
    detections[0].label = "cyclist";
    detections[0].box = BoundingBox{x_min, 124.F, 1241.F, 374.F};
    return detections;
  };
  const auto observation = [](const Detection& detection, bool supported)
  {
    TrackObservation o = observe(detection.label, 4.0, -2.0, 0.F);
    o.box = detection.box;
    o.supported = supported;
    return o;
  };
  Tracker tracker;
  int k = 0;
  for (; k < 3; ++k)
  {
    tracker.update(k * kFramePeriodS, {observation(cyclist(1190.F)[0], false)});
  }
  const std::vector<Detection> first = cyclist(1075.F);
  const TrackPrior prior = tracker.priors(k * kFramePeriodS, first)[0];
  EXPECT_TRUE(prior.has_box);
  EXPECT_EQ(prior.label, "cyclist");
  EXPECT_FLOAT_EQ(prior.box.x_min, 1075.F) << "the detector's box, not the filter's lag behind it";
  const TrackEstimate located = tracker.update(k * kFramePeriodS, {observation(first[0], true)})[0];
  EXPECT_EQ(located.id, 1U) << "the boxes without cells kept the track";

  Tracker born;  // a track born at the first cells
  born.update(k * kFramePeriodS, {observation(first[0], true)});
  ++k;
  const std::vector<Detection> second = cyclist(998.F);
  const TrackPrior kept = tracker.priors(k * kFramePeriodS, second)[0];
  const TrackPrior fresh = born.priors(k * kFramePeriodS, second)[0];
  EXPECT_FLOAT_EQ(kept.box.x_min, fresh.box.x_min);
  EXPECT_FLOAT_EQ(kept.box.x_max, fresh.box.x_max);
}

TEST(Tracker, OverlappingBoxesPassTheGateWhenThePositionJumps)
{
  // The position jumps by 5 m (a partly hidden object's estimate), far outside the gate, but
  // the box is where it was: the box overlap keeps the track, restarted there and still static.
  // A standing object does not jump: its estimate lies between the two centres until the next
  // centres tell which is right. Without overlap: a new track.
  Tracker tracker;
  for (int k = 0; k < 5; ++k)
  {
    tracker.update(k * kFramePeriodS, {observe("van", 20.0, 1.0, 300.F)});
  }
  const TrackEstimate jumped = tracker.update(0.5, {observe("van", 25.0, 1.0, 302.F)})[0];
  EXPECT_EQ(jumped.id, 1U);
  EXPECT_GT(jumped.x, 21.0);
  EXPECT_LT(jumped.x, 24.0);
  EXPECT_EQ(jumped.motion, Motion::kStatic);
  // The centre stays at the new place: so does the van, still static.
  const TrackEstimate there = tracker.update(0.6, {observe("van", 25.0, 1.0, 302.F)})[0];
  EXPECT_NEAR(there.x, 25.0, 0.1);
  EXPECT_EQ(there.motion, Motion::kStatic);
  EXPECT_NE(tracker.update(0.7, {observe("van", 35.0, 1.0, 900.F)})[0].id, 1U);
}

TEST(Tracker, TimeGoingBackOrAGapResetsTheTracks)
{
  Tracker tracker;
  EXPECT_EQ(tracker.resetReason(5.0), "");  // nothing to start over from
  tracker.update(5.0, {observe("car", 10.0, 0.0, 300.F)});
  tracker.update(5.1, {observe("car", 10.0, 0.0, 300.F)});
  EXPECT_EQ(tracker.resetReason(6.1), "");  // max_gap 1 s: still one track
  EXPECT_NE(tracker.resetReason(6.2).find("gap of 1.1"), std::string::npos) << tracker.resetReason(6.2);
  EXPECT_NE(tracker.resetReason(4.0).find("time jumped backwards by 1.1"), std::string::npos);
  EXPECT_EQ(tracker.update(4.0, {observe("car", 10.0, 0.0, 300.F)})[0].id, 2U);  // bag restarted
  tracker.update(4.1, {observe("car", 10.0, 0.0, 300.F)});
  EXPECT_EQ(tracker.update(6.0, {observe("car", 10.0, 0.0, 300.F)})[0].id, 3U);  // 1.9 s gap
  EXPECT_EQ(tracker.size(), 1U);
}

TEST(Tracker, ALabelTakesItsOwnPriorSpeed)
{
  TrackerConfig config;
  config.motion.speed_sigma = 3.0;
  config.class_speed_sigmas = {{"pedestrian", 1.5}};
  EXPECT_DOUBLE_EQ(config.motionFor("pedestrian").speed_sigma, 1.5);
  EXPECT_DOUBLE_EQ(config.motionFor("car").speed_sigma, 3.0);
  EXPECT_DOUBLE_EQ(config.motionFor("").speed_sigma, 3.0);
  EXPECT_DOUBLE_EQ(config.motionFor("pedestrian").switch_time, config.motion.switch_time);
}

TEST(Tracker, ConfigValidation)
{
  EXPECT_NO_THROW(TrackerConfig{}.validate());
  auto bad = [](auto change)
  {
    TrackerConfig c;
    change(c);
    return c;
  };
  EXPECT_THROW(Tracker(bad([](TrackerConfig& c) { c.min_hits = 0; })), std::invalid_argument);
  EXPECT_THROW(Tracker(bad([](TrackerConfig& c) { c.max_misses = -1; })), std::invalid_argument);
  EXPECT_THROW(Tracker(bad([](TrackerConfig& c) { c.gate_sigma = 0.0; })), std::invalid_argument);
  EXPECT_THROW(Tracker(bad([](TrackerConfig& c) { c.min_iou = 1.5; })), std::invalid_argument);
  EXPECT_THROW(Tracker(bad([](TrackerConfig& c) { c.iou_weight = -1.0; })), std::invalid_argument);
  EXPECT_THROW(Tracker(bad([](TrackerConfig& c) { c.position_sigma = std::nan(""); })),
               std::invalid_argument);
  EXPECT_THROW(Tracker(bad([](TrackerConfig& c) { c.box_gain = 0.0; })), std::invalid_argument);
  EXPECT_THROW(Tracker(bad([](TrackerConfig& c) { c.box_gain = 1.5; })), std::invalid_argument);
  EXPECT_THROW(Tracker(bad([](TrackerConfig& c) { c.motion.switch_time = 0.0; })), std::invalid_argument);
  EXPECT_THROW(Tracker(bad([](TrackerConfig& c) { c.motion.grid_error = 0.5; })), std::invalid_argument);
  try
  {
    Tracker(bad([](TrackerConfig& c) { c.class_speed_sigmas["cyclist"] = 0.0; }));
    FAIL() << "no exception";
  }
  catch (const std::invalid_argument& e)
  {
    EXPECT_NE(std::string(e.what()).find("motion_class_speed_sigmas/cyclist"), std::string::npos) << e.what();
  }
  EXPECT_THROW(Tracker(bad([](TrackerConfig& c) { c.class_speed_sigmas[""] = 1.0; })), std::invalid_argument);
  Tracker tracker;
  EXPECT_THROW(tracker.setConfig(bad([](TrackerConfig& c) { c.max_gap = 0.0; })), std::invalid_argument);
  EXPECT_DOUBLE_EQ(tracker.config().max_gap, TrackerConfig{}.max_gap);
}

TEST(Tracker, BoxOverlap)
{
  EXPECT_DOUBLE_EQ(boxOverlap({0.F, 0.F, 10.F, 10.F}, {0.F, 0.F, 10.F, 10.F}), 1.0);
  EXPECT_DOUBLE_EQ(boxOverlap({0.F, 0.F, 10.F, 10.F}, {5.F, 0.F, 15.F, 10.F}), 50.0 / 150.0);
  EXPECT_DOUBLE_EQ(boxOverlap({0.F, 0.F, 10.F, 10.F}, {10.F, 0.F, 20.F, 10.F}), 0.0);
  EXPECT_DOUBLE_EQ(boxOverlap({0.F, 0.F, 0.F, 0.F}, {0.F, 0.F, 0.F, 0.F}), 0.0);
}

}  // namespace grid_vision_fusion
