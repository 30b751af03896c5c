// Unit tests of the tracker on constructed sequences: track birth and confirmation, crossing
// objects, an occluded object reappearing, a parked car passed at speed, a car that starts, the
// filter's velocity, label gating and resets.
#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>

#include "grid_vision_fusion/fusion/tracker.h"

namespace grid_vision_fusion
{
namespace
{
constexpr double kFramePeriodS = 0.1;  // 10 Hz, as KITTI

/// An observation of a `label` at (x, y) with a box of 40 px around column u.
TrackObservation observe(const std::string& label, double x, double y, float u,
                         Motion motion = Motion::kStatic)
{
  TrackObservation o;
  o.label = label;
  o.x = x;
  o.y = y;
  o.box = BoundingBox{u - 20.F, 100.F, u + 20.F, 180.F};
  o.motion = motion;
  o.static_points = motion == Motion::kDynamic ? 0 : 10;
  o.dynamic_points = motion == Motion::kDynamic ? 10 : 0;
  o.grid_cells = 10;  // the object's cluster; its cells carry no velocity
  return o;
}

/// A dynamic observation moving at (vx, vy), the grid's velocity given.
TrackObservation moving(const std::string& label, double x, double y, float u, double vx, double vy)
{
  TrackObservation o = observe(label, x, y, u, Motion::kDynamic);
  o.has_velocity = true;
  o.vx = vx;
  o.vy = vy;
  return o;
}
}  // namespace

TEST(Tracker, ATrackIsConfirmedAfterMinHitsAndKeepsItsId)
{
  Tracker tracker;  // min_hits 2
  const auto first = tracker.update(0.0, {observe("car", 10.0, 0.0, 300.F)});
  ASSERT_EQ(first.size(), 1U);
  EXPECT_FALSE(first[0].confirmed);
  EXPECT_EQ(first[0].id, 1U);
  for (int k = 1; k < 10; ++k)
  {
    const auto e = tracker.update(k * kFramePeriodS, {observe("car", 10.0, 0.0, 300.F)});
    ASSERT_EQ(e.size(), 1U);
    EXPECT_TRUE(e[0].confirmed);
    EXPECT_EQ(e[0].id, 1U);
    EXPECT_EQ(e[0].motion, Motion::kStatic);
  }
  // A tentative track missed once is dropped: a single detection never becomes a track.
  tracker.update(1.0, {observe("car", 10.0, 0.0, 300.F), observe("car", 30.0, 5.0, 600.F)});
  const auto later = tracker.update(1.1, {observe("car", 10.0, 0.0, 300.F)});
  EXPECT_EQ(tracker.size(), 1U);
  EXPECT_EQ(later[0].id, 1U);
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
    if (k == 1)
    {
      id_a = e[0].id;
      id_b = e[1].id;
      EXPECT_NE(id_a, id_b);
    }
    if (k >= 1)
    {
      EXPECT_EQ(e[0].id, id_a) << "t = " << t;
      EXPECT_EQ(e[1].id, id_b) << "t = " << t;
      EXPECT_TRUE(e[0].confirmed && e[1].confirmed);
    }
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
  // The ego passes a parked car: its centre estimate wanders by up to ±0.4 m as the visible
  // faces change, and every fifth image the region holds more dynamic than static cells
  // (motion smear of the grid). The verdict stays static throughout.
  Tracker tracker;
  for (int k = 0; k < 60; ++k)
  {
    const double wobble = 0.4 * std::sin(0.7 * k);
    TrackObservation o = observe("car", 20.0 + wobble, -5.0 - 0.5 * wobble, static_cast<float>(100 + 15 * k));
    if (k % 5 == 4)
    {
      o.static_points = 4;
      o.dynamic_points = 6;
      o.motion = Motion::kDynamic;
      o.has_velocity = true;
      o.vx = -3.0;  // the smear's spurious velocity
    }
    const auto e = tracker.update(k * kFramePeriodS, {o});
    EXPECT_EQ(e[0].motion, Motion::kStatic) << "image " << k;
    EXPECT_EQ(e[0].id, 1U);
  }
}

TEST(Tracker, ACarThatStartsIsDynamicWithinHalfASecond)
{
  // Parked: the score saturates at −2 (−motion_evidence_limit). Driving off, the grid's regions
  // turn dynamic (+1 per image), but at the first image the speed still says standing (−2: the
  // window's average speed is below half the threshold): after the 5th dynamic image (0.4 s
  // after the first) the score is +2 >= 1.5.
  Tracker tracker;
  int k = 0;
  for (; k < 30; ++k)  // parked for 3 s: the evidence saturates at −motion_evidence_limit
  {
    EXPECT_EQ(tracker.update(k * kFramePeriodS, {observe("car", 12.0, 3.0, 400.F)})[0].motion,
              Motion::kStatic);
  }
  const int start = k;
  double x = 12.0;
  for (; k < start + 5; ++k)  // then drives off: dynamic regions from now on
  {
    x += 0.3;
    const auto e = tracker.update(k * kFramePeriodS, {moving("car", x, 3.0, 400.F, 3.0, 0.0)});
    if (k == start + 4)
    {
      EXPECT_EQ(e[0].motion, Motion::kDynamic) << "still static 0.4 s after the start";
      EXPECT_GT(e[0].vx, 2.0);
    }
  }
}

/// An observation whose region the grid splits evenly (no evidence either way).
TrackObservation undecided(double x, double y)
{
  TrackObservation o = observe("car", x, y, 400.F);
  o.static_points = 5;
  o.dynamic_points = 5;
  return o;
}

TEST(Tracker, AStartFromRestCountsBeforeTheSustainedSpeedDoes)
{
  // Standing for 3 s (score −3), then rolling off at 2 m/s while the grid's regions stay split
  // evenly. At image 2 (0.2 s) the second half of the history has moved 0.6 m steadily: its
  // observed speed passes 1 m/s, +1.5 per image, without waiting for the filter's speed, which
  // lags: dynamic after 3 images (−3 → +1.5), at image 4, 0.4 s after the start. (With the
  // filtered positions the progressive speed lagged as well: 0.6 s. Before it counted alone:
  // 0.8 s. The sustained speed needs its first half to move as well: later still. A window of
  // 1 s, a threshold of 1 m/s, limit 3 and weight 1.5, set here, keep these times whatever the
  // defaults.)
  TrackerConfig config;
  config.motion_speed_window = 1.0;
  config.motion_speed_threshold = 1.0;
  config.motion_evidence_limit = 3.0;
  config.speed_evidence = 1.5;
  Tracker tracker(config);
  int k = 0;
  for (; k < 30; ++k)
  {
    tracker.update(k * kFramePeriodS, {observe("car", 12.0, 3.0, 400.F)});
  }
  const int start = k;
  for (; k <= start + 8; ++k)
  {
    const double x = 12.0 + 0.2 * (k - start + 1);
    const Motion motion = tracker.update(k * kFramePeriodS, {undecided(x, 3.0)})[0].motion;
    EXPECT_EQ(motion, k < start + 4 ? Motion::kStatic : Motion::kDynamic) << "image " << k - start;
  }
}

TEST(Tracker, ASlowStartWithinItsCellsCountsProgressively)
{
  // A pedestrian standing for 3 s, then walking off at 1.2 m/s; its centre estimate moves in
  // whole cells of 0.2 m (steps of 0 or 0.2 m) and the grid calls its regions static (-1 per
  // image). The steps of zero are the object within its cell, not a step back: the progressive
  // speed passes, the old track's static votes no longer count against it, and the verdict
  // turns dynamic 0.5 s after the start (with the filtered positions and the votes: 0.9 s; when a
  // step of zero broke the progression, only through the sustained speed: 1.2 s).
  Tracker tracker;
  int k = 0;
  for (; k < 30; ++k)
  {
    tracker.update(k * kFramePeriodS, {observe("pedestrian", 12.0, 3.0, 400.F)});
  }
  const int start = k;
  for (; k <= start + 15; ++k)
  {
    const double walked = 1.2 * (k - start + 1) * kFramePeriodS;
    const double x = 12.0 + 0.2 * std::floor(walked / 0.2);
    const Motion motion = tracker.update(k * kFramePeriodS, {observe("pedestrian", x, 3.0, 400.F)})[0].motion;
    EXPECT_EQ(motion, k < start + 5 ? Motion::kStatic : Motion::kDynamic) << "image " << k - start;
  }
}

TEST(Tracker, AReturnAfterAJumpOfTheCentreEstimateIsNoStart)
{
  // A standing car whose centre estimate jumps 2 m (another part of it seen: the track
  // restarts, its box still overlaps) and then walks back to where it was over 0.5 s, steadily,
  // as the cells of the rest of the car come into view again. Its regions are split evenly. The
  // walk back looks like a start from rest to the speed tests; it heads back to the position
  // before the jump, so it gives no speed evidence, and the verdict stays static.
  Tracker tracker;
  for (int k = 0; k < 60; ++k)
  {
    double x = 12.0;
    if (k >= 30 && k < 36)
    {
      x = 14.0 - 0.4 * (k - 30);  // 14.0, 13.6, ..., 12.0
    }
    const TrackEstimate e = tracker.update(k * kFramePeriodS, {undecided(x, 3.0)})[0];
    if (k >= 20)
    {
      EXPECT_EQ(e.motion, Motion::kStatic) << "image " << k;
    }
  }
}

/// An observation whose regions are split evenly and whose cells have the grid's velocity
/// (vx, vy), `agreement` of its 20 cells near it.
TrackObservation withGridVelocity(double x, double y, double vx, double vy, double agreement)
{
  TrackObservation o = undecided(x, y);
  o.grid_vx = vx;
  o.grid_vy = vy;
  o.grid_velocity_agreement = agreement;
  o.grid_cells = 20;
  return o;
}

TEST(Tracker, TheGridsVelocityFindsANewMoverSooner)
{
  // A new track of a car at 8 m/s along x, its regions split evenly. Its cells agree on the
  // velocity and its observed position moves the same way: +2.5 from the third image on,
  // dynamic there (0.2 s). Without the grid's velocity, the speed tests wait for half a window
  // (0.5 s); with cells that scatter (agreement 0.2) or a velocity across the displacement, the
  // same.
  auto dynamicFrom = [](double grid_evidence, double vx, double vy, double agreement)
  {
    TrackerConfig config;
    config.grid_velocity_evidence = grid_evidence;
    config.early_displacement = 0.0;  // this test is about the grid's velocity alone
    Tracker tracker(config);
    for (int k = 0; k < 15; ++k)
    {
      const double t = k * kFramePeriodS;
      if (tracker.update(t, {withGridVelocity(10.0 + 8.0 * t, 3.0, vx, vy, agreement)})[0].motion ==
          Motion::kDynamic)
      {
        return k;
      }
    }
    return -1;
  };
  EXPECT_EQ(dynamicFrom(2.5, 8.0, 0.0, 0.9), 2);
  EXPECT_EQ(dynamicFrom(0.0, 8.0, 0.0, 0.9), 5);
  EXPECT_EQ(dynamicFrom(2.5, 8.0, 0.0, 0.2), 5);
  EXPECT_EQ(dynamicFrom(2.5, 0.0, 8.0, 0.9), 5);
}

TEST(Tracker, AGridVelocityWithoutDisplacementIsNoEvidence)
{
  // A parked car whose cells agree on 3 m/s (cells flickering as the ego passes) while its
  // observed position stands still: the track has not moved that way, the verdict stays static.
  Tracker tracker;
  for (int k = 0; k < 30; ++k)
  {
    TrackObservation o = withGridVelocity(12.0, 3.0, 3.0, 0.0, 1.0);
    o.static_points = 10;
    o.dynamic_points = 0;
    EXPECT_EQ(tracker.update(k * kFramePeriodS, {o})[0].motion, Motion::kStatic) << "image " << k;
  }
}

/// Runs `tracker` on `before` images of `first(k)`, then on up to `after` images of `second(k)`
/// (k counts the images of each phase from 0, 10 Hz throughout). Returns k of the first image of
/// the second phase whose verdict is `wanted`, -1 when none is.
template <typename First, typename Second>
int firstVerdictAfter(Tracker& tracker, int before, First first, int after, Second second, Motion wanted)
{
  for (int k = 0; k < before; ++k)
  {
    tracker.update(k * kFramePeriodS, {first(k)});
  }
  for (int k = 0; k < after; ++k)
  {
    if (tracker.update((before + k) * kFramePeriodS, {second(k)})[0].motion == wanted)
    {
      return k;
    }
  }
  return -1;
}

/// No image before the second phase.
TrackObservation nothing(int /*k*/)
{
  return TrackObservation{};
}

TEST(Tracker, AnObjectMovingPastThePositionBeforeAJumpIsNoReturn)
{
  // A pedestrian's track that followed the wall behind it (its cells won the region) for 1 s,
  // then jumps to the pedestrian, 4 m nearer along x and 2.4 m to the side, who walks on along x
  // at 1.5 m/s: toward the wall's position (31° off) but passing it 2.4 m away, no estimate
  // heading back. Its regions are split evenly; its speed counts once half the window is filled and
  // the progressive speed has its images. The same walk straight at the wall's position is taken
  // for a return until a window has passed since the jump.
  auto pedestrian = [](double x, double y)
  {
    TrackObservation o = undecided(x, y);
    o.label = "pedestrian";
    return o;
  };
  auto walkingFrom = [&](double lateral_offset)
  {
    Tracker tracker;
    return firstVerdictAfter(
        tracker, 10, [&](int /*k*/) { return pedestrian(18.0, 5.0); }, 15,
        [&](int k) { return pedestrian(14.0 + 0.15 * k, 5.0 - lateral_offset); }, Motion::kDynamic);
  };
  EXPECT_EQ(walkingFrom(2.4), 6);
  EXPECT_GE(walkingFrom(0.0), 10);  // no speed evidence for a window after the jump
}

TEST(Tracker, AFastNewTrackCountsItsEarlyDisplacement)
{
  // A new track of a car at 10 m/s along x whose regions the grid splits evenly (the first
  // scans of a drive: no cell has a history yet). Its observed position has moved 2 m over 2
  // steady steps at the third image: +2 there, dynamic (0.2 s). Without the early test the speed
  // tests wait for half a window (image 5); so they do for an object seen as 2 cells (a corner
  // coming into view, whose centre estimate moves as more of it shows).
  auto dynamicFrom = [](double early_displacement, std::uint32_t cells)
  {
    TrackerConfig config;
    config.early_displacement = early_displacement;
    Tracker tracker(config);
    auto driving = [cells](int k)
    {
      TrackObservation o = undecided(10.0 + 1.0 * k, 3.0);
      o.grid_cells = cells;
      return o;
    };
    return firstVerdictAfter(tracker, 0, nothing, 15, driving, Motion::kDynamic);
  };
  EXPECT_EQ(dynamicFrom(TrackerConfig{}.early_displacement, 10), 2);
  EXPECT_EQ(dynamicFrom(0.0, 10), 5);
  EXPECT_EQ(dynamicFrom(TrackerConfig{}.early_displacement, 2), 5);
}

TEST(Tracker, AnEarlyJumpOfTheCentreEstimateIsNoEarlyDisplacement)
{
  // A parked car whose first centre estimate lies 1.5 m off (a part of it seen) and then stays
  // put: one step carries the whole displacement, not a steady one, so the early test gives
  // nothing; its regions lean static and the verdict stays static.
  Tracker tracker;
  for (int k = 0; k < 10; ++k)
  {
    TrackObservation o = observe("car", k == 0 ? 13.5 : 12.0, 3.0, 400.F);
    o.static_points = 6;
    o.dynamic_points = 4;
    EXPECT_EQ(tracker.update(k * kFramePeriodS, {o})[0].motion, Motion::kStatic) << "image " << k;
  }
}

TEST(Tracker, AStopIsSeenOnceThePositionStandsStill)
{
  // A car driving at 3 m/s for 3 s (dynamic), then stopping dead, its regions split evenly
  // throughout. Its observed position stands still from the stop on: after half a second
  // (still_window) each image gives −2 and the verdict turns static 0.6 s after the stop. The
  // filter's speed and the average over the window decay later: without the still test, the
  // verdict turns static a second after the stop.
  auto staticAfter = [](double still_window)
  {
    TrackerConfig config;
    config.still_window = still_window;
    config.still_short_window = 0.0;  // the next test's
    Tracker tracker(config);
    return firstVerdictAfter(
        tracker, 30, [](int k) { return undecided(10.0 + 0.3 * k, 3.0); }, 30,
        [](int /*k*/) { return undecided(10.0 + 0.3 * 30, 3.0); }, Motion::kStatic);
  };
  EXPECT_EQ(staticAfter(TrackerConfig{}.still_window), 6);
  EXPECT_GE(staticAfter(0.0), 10);
}

TEST(Tracker, AStopWithACellOfJitterIsSeenOverTwoScans)
{
  // The same car, but once it stands its observed position jumps by a cell and back every
  // fourth image (the cells the lidar hits change): there is always such a jump within the
  // last 0.5 s, and the still test over motion_still_window never passes. Over the last two
  // scans (still_short_window) it passes in one image of four: two of them (−2 each) take the
  // score from +2 to the static side.
  auto staticAfter = [](double short_window)
  {
    TrackerConfig config;
    config.still_short_window = short_window;
    Tracker tracker(config);
    return firstVerdictAfter(
        tracker, 30, [](int k) { return undecided(10.0 + 0.3 * k, 3.0); }, 30,
        [](int k) { return undecided(10.0 + 0.3 * 30 + (k % 4 == 1 ? 0.25 : 0.0), 3.0); }, Motion::kStatic);
  };
  EXPECT_EQ(staticAfter(TrackerConfig{}.still_short_window), 8);  // the passes at 4 and 8
  const int without = staticAfter(0.0);  // the filter's speed and the window's average: 13
  EXPECT_TRUE(without < 0 || without >= 11) << "without the short window: " << without;
}

TEST(Tracker, AMeasuredSpeedOverridesTheStaticVoteOfAnOldTrackOnly)
{
  // A pedestrian standing for 3 s, then walking off at 1.2 m/s; the grid calls its regions
  // static (−1 per image) throughout, as it does for motion slower than a cell per scan. Once
  // the track's own speed passes the threshold, the static vote of an old track no longer
  // counts against it: dynamic sooner than with the vote. A track that is born walking keeps
  // the vote in its first second (its displacement may still be its centre estimate settling):
  // there the override changes nothing.
  auto dynamicAfter = [](bool overrides, int standing_images)
  {
    TrackerConfig config;
    config.speed_overrides_region = overrides;
    Tracker tracker(config);
    return firstVerdictAfter(
        tracker, standing_images, [](int /*k*/) { return observe("pedestrian", 12.0, 3.0, 400.F); }, 31,
        [](int k) { return observe("pedestrian", 12.0 + 0.12 * (k + 1), 3.0, 400.F); }, Motion::kDynamic);
  };
  const int with_override = dynamicAfter(true, 30);
  const int without = dynamicAfter(false, 30);
  EXPECT_GT(with_override, 0);
  EXPECT_LT(with_override, without);
  EXPECT_EQ(dynamicAfter(true, 0), dynamicAfter(false, 0));
  EXPECT_GT(dynamicAfter(true, 0), 0);
}

TEST(Tracker, AJitterOfTheCentreEstimateIsNoStepBack)
{
  // A car standing for 3 s, then rolling off at 2 m/s, regions split evenly; its centre
  // estimate jitters back by 2 cm at every third image (its orientation fit). Below
  // step_tolerance that is no step back: the progressive speed passes as without the jitter.
  // With no tolerance the jitter breaks every progression and the verdict waits for the
  // sustained speed.
  auto dynamicAfter = [](double tolerance)
  {
    TrackerConfig config;
    config.step_tolerance = tolerance;
    Tracker tracker(config);
    auto rolling = [](int k)
    {
      // 0.3 m per image, 0.02 m back at every third one
      return undecided(12.0 + 0.3 * (k + 1 - (k + 1) / 3) - 0.02 * ((k + 1) / 3), 3.0);
    };
    return firstVerdictAfter(
        tracker, 30, [](int /*k*/) { return undecided(12.0, 3.0); }, 31, rolling, Motion::kDynamic);
  };
  const int tolerant = dynamicAfter(TrackerConfig{}.step_tolerance);
  EXPECT_GT(tolerant, 0);
  EXPECT_LT(tolerant, dynamicAfter(0.0));
}

TEST(Tracker, AJumpOfTheCentreEstimateIsNoStart)
{
  // A standing car whose centre estimate jumps by 1.5 m once (another cluster) and stays there:
  // one step carries the whole displacement, so neither the sustained nor the progressive speed
  // counts; the verdict stays static. (The filtered position, which spreads the jump over the
  // next images, would pass the sustained test.)
  Tracker tracker;
  for (int k = 0; k < 60; ++k)
  {
    const double x = k < 30 ? 12.0 : 13.5;
    const TrackEstimate e = tracker.update(k * kFramePeriodS, {undecided(x, 3.0)})[0];
    if (k >= 20)
    {
      EXPECT_EQ(e.motion, Motion::kStatic) << "image " << k;
    }
  }
}

TEST(Tracker, TheFilterFindsTheVelocityFromPositionsAlone)
{
  // No grid velocity: positions only, a car at (6, −2) m/s. After 3 s the filter's velocity is
  // within 0.2 m/s, its speed uncertainty below 0.5 m/s.
  Tracker tracker;
  TrackEstimate e;
  for (int k = 0; k <= 30; ++k)
  {
    const double t = k * kFramePeriodS;
    e = tracker.update(t, {observe("car", 10.0 + 6.0 * t, 4.0 - 2.0 * t, 500.F)})[0];
  }
  EXPECT_NEAR(e.vx, 6.0, 0.2);
  EXPECT_NEAR(e.vy, -2.0, 0.2);
  EXPECT_LT(e.speed_sigma, 0.6);
  EXPECT_NEAR(e.window_speed, std::hypot(6.0, -2.0), 0.2);
  EXPECT_NEAR(e.age, 3.0, 1e-9);
  EXPECT_EQ(e.hits, 31);
}

TEST(Tracker, SpeedEvidenceFindsAMoverTheGridCallsStatic)
{
  // A car creeping at 2 m/s whose regions the grid calls static (−1 per image): with a speed
  // evidence of weight 2 (+2 per image once the track is 0.5 s old and both speeds exceed
  // 1 m/s) the verdict turns dynamic; without, it stays static.
  for (const double weight : {0.0, 2.0})
  {
    TrackerConfig config;
    config.speed_evidence = weight;
    Tracker tracker(config);
    Motion last = Motion::kUnknown;
    for (int k = 0; k <= 40; ++k)
    {
      const double t = k * kFramePeriodS;
      last = tracker.update(t, {observe("car", 10.0 + 2.0 * t, 0.0, 500.F)})[0].motion;
    }
    EXPECT_EQ(last, weight > 0.0 ? Motion::kDynamic : Motion::kStatic) << "weight " << weight;
  }
}

TEST(Tracker, TheVerdictDwellsAfterAChangeUnlessTheEvidenceSaturates)
{
  // Parked for 3 s, dynamic regions for 0.6 s (the score climbs from -3 to +3, the verdict turns
  // dynamic at +1.5), then static regions again. Returns when the verdict turned static.
  auto staticAgainAt = [](std::uint32_t static_points, std::uint32_t dynamic_points, double& changed_at)
  {
    TrackerConfig config;
    config.speed_evidence = 0.0;  // the grid's evidence alone, for a hand count
    config.motion_evidence_limit = 3.0;
    Tracker tracker(config);
    int k = 0;
    for (; k < 30; ++k)
    {
      tracker.update(k * kFramePeriodS, {observe("car", 12.0, 3.0, 400.F)});
    }
    changed_at = -1.0;
    for (; k < 36; ++k)
    {
      if (tracker.update(k * kFramePeriodS, {observe("car", 12.0, 3.0, 400.F, Motion::kDynamic)})[0].motion ==
              Motion::kDynamic &&
          changed_at < 0.0)
      {
        changed_at = k * kFramePeriodS;
      }
    }
    for (; k < 80; ++k)
    {
      TrackObservation o = observe("car", 12.0, 3.0, 400.F);
      o.static_points = static_points;
      o.dynamic_points = dynamic_points;
      if (tracker.update(k * kFramePeriodS, {o})[0].motion == Motion::kStatic)
      {
        return k * kFramePeriodS;
      }
    }
    return -1.0;
  };
  double changed_at = 0.0;
  // Evidence -0.25 per image: the score passes -1.5 at t = 5.3 s, 1.9 s after the change
  // (3.4 s), but the verdict dwells until 2 s after it.
  EXPECT_NEAR(staticAgainAt(5, 3, changed_at), 5.4, 1e-6);
  EXPECT_NEAR(changed_at, 3.4, 1e-6);
  // Evidence -1 per image: the score reaches -3, the opposite limit, at 4.1 s, which ends the
  // dwell (a verdict on thin evidence does not outlast evidence swung all the way against it).
  EXPECT_NEAR(staticAgainAt(10, 0, changed_at), 4.1, 1e-6);
}

TEST(Tracker, AYoungTrackFollowsItsRegionsWithoutFlicker)
{
  // Regions alternating static / dynamic with weak counts (6 vs 5 cells: evidence ±1/11): the
  // score never reaches a threshold, so the track takes its regions' verdicts, like the
  // per-frame output, but after its first change (image 1) it dwells 2 s: no flicker.
  TrackerConfig config;
  config.speed_evidence = 0.0;
  Tracker tracker(config);
  for (int k = 0; k < 30; ++k)
  {
    TrackObservation o = observe("cyclist", 15.0, 2.0, 500.F, k % 2 ? Motion::kDynamic : Motion::kStatic);
    o.static_points = k % 2 ? 5 : 6;
    o.dynamic_points = k % 2 ? 6 : 5;
    const Motion m = tracker.update(k * kFramePeriodS, {o})[0].motion;
    const Motion expected = k == 0   ? Motion::kStatic
                            : k < 21 ? Motion::kDynamic
                            : k % 2  ? Motion::kDynamic
                                     : Motion::kStatic;
    if (k <= 21)
    {
      EXPECT_EQ(m, expected) << "image " << k;
    }
  }
}

TEST(Tracker, OnlyTheSameLabelIsAssociated)
{
  Tracker tracker;
  tracker.update(0.0, {observe("car", 10.0, 0.0, 300.F)});
  const auto e = tracker.update(0.1, {observe("pedestrian", 10.0, 0.0, 300.F)});
  EXPECT_EQ(e[0].id, 2U);
  EXPECT_FALSE(e[0].confirmed);
}

TEST(Tracker, OverlappingBoxesPassTheGateWhenThePositionJumps)
{
  // The position jumps by 5 m (a partly hidden object's estimate), far outside the gate, but
  // the box is where it was: the box overlap keeps the track. Without overlap: a new track.
  Tracker tracker;
  for (int k = 0; k < 5; ++k)
  {
    tracker.update(k * kFramePeriodS, {observe("van", 20.0, 1.0, 300.F)});
  }
  EXPECT_EQ(tracker.update(0.5, {observe("van", 25.0, 1.0, 302.F)})[0].id, 1U);
  EXPECT_NE(tracker.update(0.6, {observe("van", 35.0, 1.0, 900.F)})[0].id, 1U);
}

// A parked car observed at x = 10 for 1 s, then once 1.5 m off (its centre estimate jumped)
// and back: the robust update moves the track and its speed less than the plain one, and a
// steady displacement still moves it.
TEST(Tracker, TheRobustUpdateDiscountsAJumpOfThePosition)
{
  auto run = [](double robust_sigma, double jump_x)
  {
    TrackerConfig config;
    config.robust_sigma = robust_sigma;
    Tracker tracker(config);
    double t = 0.0;
    for (int k = 0; k < 10; ++k, t += kFramePeriodS)
    {
      tracker.update(t, {observe("car", 10.0, 0.0, 300.F)});
    }
    return tracker.update(t, {observe("car", jump_x, 0.0, 300.F)}).at(0);
  };
  const TrackEstimate plain = run(0.0, 11.5);
  const TrackEstimate robust = run(2.0, 11.5);
  ASSERT_TRUE(plain.confirmed);
  ASSERT_TRUE(robust.confirmed);
  EXPECT_GT(plain.x - 10.0, 0.3);
  EXPECT_LT(robust.x - 10.0, 0.8 * (plain.x - 10.0));
  EXPECT_LT(std::abs(robust.vx), 0.8 * std::abs(plain.vx));
  // Within robust_sigma the update is the plain one.
  EXPECT_DOUBLE_EQ(run(2.0, 10.2).x, run(0.0, 10.2).x);
}

TEST(Tracker, TimeGoingBackOrAGapResetsTheTracks)
{
  Tracker tracker;
  tracker.update(5.0, {observe("car", 10.0, 0.0, 300.F)});
  tracker.update(5.1, {observe("car", 10.0, 0.0, 300.F)});
  EXPECT_EQ(tracker.update(4.0, {observe("car", 10.0, 0.0, 300.F)})[0].id, 2U);  // bag restarted
  tracker.update(4.1, {observe("car", 10.0, 0.0, 300.F)});
  EXPECT_EQ(tracker.update(6.0, {observe("car", 10.0, 0.0, 300.F)})[0].id, 3U);  // 1.9 s gap
  EXPECT_EQ(tracker.size(), 1U);
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
  EXPECT_THROW(Tracker(bad([](TrackerConfig& c) { c.position_sigma = std::nan(""); })),
               std::invalid_argument);
  EXPECT_THROW(Tracker(bad([](TrackerConfig& c) { c.motion_switch_evidence = 4.0; })), std::invalid_argument);
  EXPECT_THROW(Tracker(bad([](TrackerConfig& c) { c.speed_evidence = -1.0; })), std::invalid_argument);
  EXPECT_THROW(Tracker(bad([](TrackerConfig& c) { c.motion_speed_window = 0.0; })), std::invalid_argument);
  EXPECT_THROW(Tracker(bad([](TrackerConfig& c) { c.motion_min_dwell = -1.0; })), std::invalid_argument);
  EXPECT_THROW(Tracker(bad([](TrackerConfig& c) { c.robust_sigma = -0.5; })), std::invalid_argument);
  EXPECT_THROW(Tracker(bad([](TrackerConfig& c) { c.grid_velocity_evidence = -1.0; })),
               std::invalid_argument);
  EXPECT_THROW(Tracker(bad([](TrackerConfig& c) { c.grid_velocity_agreement = 0.0; })),
               std::invalid_argument);
  EXPECT_THROW(Tracker(bad([](TrackerConfig& c) { c.grid_velocity_min_cells = 0; })), std::invalid_argument);
  EXPECT_THROW(Tracker(bad([](TrackerConfig& c) { c.early_displacement = -1.0; })), std::invalid_argument);
  EXPECT_THROW(Tracker(bad([](TrackerConfig& c) { c.step_tolerance = -0.1; })), std::invalid_argument);
  EXPECT_THROW(Tracker(bad([](TrackerConfig& c) { c.still_window = -0.1; })), std::invalid_argument);
  EXPECT_THROW(Tracker(bad([](TrackerConfig& c) { c.still_window = 1.5; })), std::invalid_argument);
  EXPECT_THROW(Tracker(bad([](TrackerConfig& c) { c.still_short_window = -0.1; })), std::invalid_argument);
  EXPECT_THROW(Tracker(bad([](TrackerConfig& c) { c.still_short_window = 1.5; })), std::invalid_argument);
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
