// Unit tests of the tracking metrics (CLEAR MOT, identity measures, motion flicker) on
// hand-made sequences; every figure is worked out in the comment next to it.
#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>

#include "grid_vision_fusion/evaluation/evaluation.h"

namespace grid_vision_fusion
{
namespace
{
const BoundingBox kBox{100.F, 100.F, 199.F, 199.F};
const BoundingBox kElsewhere{400.F, 100.F, 499.F, 199.F};

EvalObject object(int frame, std::int64_t track, Motion motion, BoundingBox box = kBox,
                  const std::string& label = "car")
{
  EvalObject o;
  o.frame = "000000000" + std::to_string(frame);
  o.time_s = 0.1 * frame;
  o.label = label;
  o.motion = motion;
  o.box = box;
  o.track_id = track;
  o.longitudinal_m = 10.0;
  return o;
}
}  // namespace

TEST(TrackingEvaluation, SwitchFragmentationMotaIdf1AndFlicker)
{
  // One parked car (tracklet 7) in frames 0-4. The tracker reports it as id 1 in frames 0, 1,
  // loses it in frame 2, reports it as id 2 in frames 3, 4, plus a false car (id 9) in frame 4.
  // A difficult truth (tracklet 8) in frame 0 has a detection (id 5): ignored.
  std::vector<EvalObject> truth, detections;
  for (int f = 0; f < 5; ++f)
  {
    truth.push_back(object(f, 7, Motion::kStatic));
  }
  EvalObject difficult = object(0, 8, Motion::kStatic, kElsewhere);
  difficult.difficult = true;
  truth.push_back(difficult);
  detections.push_back(object(0, 5, Motion::kStatic, kElsewhere));
  detections.push_back(object(0, 1, Motion::kStatic));
  detections.push_back(object(1, 1, Motion::kDynamic));  // motion change 1 (t = 0.1)
  detections.push_back(object(3, 2, Motion::kStatic));   // change 2 at t = 0.3: a flicker
  detections.push_back(object(4, 2, Motion::kStatic));
  detections.push_back(object(4, 9, Motion::kStatic, kElsewhere));

  const TrackingMetrics m = evaluateTracking(truth, detections, TrackingEvaluationConfig{});
  EXPECT_EQ(m.ground_truth, 5U);
  EXPECT_EQ(m.matches, 4U);
  EXPECT_EQ(m.misses, 1U);           // frame 2
  EXPECT_EQ(m.false_positives, 1U);  // id 9; id 5 matches the difficult truth only
  EXPECT_EQ(m.id_switches, 1U);      // 1 -> 2 in frame 3
  EXPECT_EQ(m.fragmentations, 1U);   // tracked again in frame 3 after the miss
  EXPECT_DOUBLE_EQ(m.mota, 1.0 - 3.0 / 5.0);
  EXPECT_DOUBLE_EQ(m.id_switches_per_100, 25.0);
  // Identities: tracklet 7 is co-matched 2 frames with id 1 and 2 with id 2; one of them is its
  // identity: IDTP 2, IDFN 5 - 2 = 3, IDFP (2 + 2 + 1) - 2 = 3; IDF1 = 4 / (4 + 3 + 3).
  EXPECT_EQ(m.idtp, 2U);
  EXPECT_EQ(m.idfn, 3U);
  EXPECT_EQ(m.idfp, 3U);
  EXPECT_DOUBLE_EQ(m.idf1, 0.4);
  EXPECT_EQ(m.truth_tracks, 1U);
  EXPECT_EQ(m.mostly_tracked, 1U);  // 4 of 5 frames
  EXPECT_EQ(m.motion_changes, 2U);
  EXPECT_EQ(m.motion_flickers, 1U);
  EXPECT_EQ(m.flickering_tracks, 1U);
}

TEST(TrackingEvaluation, AKeptCorrespondenceWinsOverABetterOverlap)
{
  // Frame 0: truth 1 matched to id 10. Frame 1: ids 10 and 11 both overlap truth 1, id 11
  // better; the correspondence with id 10 is kept (no switch), id 11 is a false positive.
  const BoundingBox shifted{105.F, 100.F, 204.F, 199.F};
  std::vector<EvalObject> truth{object(0, 1, Motion::kStatic), object(1, 1, Motion::kStatic)};
  std::vector<EvalObject> detections{object(0, 10, Motion::kStatic), object(1, 10, Motion::kStatic, shifted),
                                     object(1, 11, Motion::kStatic, kBox)};
  const TrackingMetrics m = evaluateTracking(truth, detections, TrackingEvaluationConfig{});
  EXPECT_EQ(m.id_switches, 0U);
  EXPECT_EQ(m.matches, 2U);
  EXPECT_EQ(m.false_positives, 1U);
  EXPECT_DOUBLE_EQ(m.mota, 0.5);
  EXPECT_DOUBLE_EQ(m.idf1, 2.0 * 2.0 / (2.0 * 2.0 + 1.0 + 0.0));  // IDTP 2, IDFP 1, IDFN 0
}

TEST(TrackingEvaluation, PerFrameIndicesSwitchAndTruthChangesAreNoFlicker)
{
  // Two cars in every frame; the per-frame output numbers them 0, 1 in detection order, which
  // swaps in frame 1: two id switches. Car 1 starts moving in frame 2 and the output follows:
  // a motion change with a truth change is not counted.
  std::vector<EvalObject> truth, detections;
  for (int f = 0; f < 3; ++f)
  {
    const Motion second = f >= 2 ? Motion::kDynamic : Motion::kStatic;
    truth.push_back(object(f, 0, Motion::kStatic));
    truth.push_back(object(f, 1, second, kElsewhere));
    const bool swapped = f == 1;
    detections.push_back(object(f, swapped ? 1 : 0, Motion::kStatic));
    detections.push_back(object(f, swapped ? 0 : 1, second, kElsewhere));
  }
  const TrackingMetrics m = evaluateTracking(truth, detections, TrackingEvaluationConfig{});
  EXPECT_EQ(m.id_switches, 4U);  // both in frame 1, both back in frame 2
  EXPECT_EQ(m.motion_changes, 0U);
  EXPECT_EQ(m.motion_flickers, 0U);
  EXPECT_DOUBLE_EQ(m.mota, 1.0 - 4.0 / 6.0);
}

TEST(TrackingEvaluation, TimeToTheFirstDynamicVerdict)
{
  // A car (tracklet 3) standing in frames 0-1, moving at 0.6 m/s in frame 2, at 2 m/s from frame
  // 3 on: reported static until frame 5, dynamic from frame 6: 0.3 s after its first match at
  // 1 m/s or more. A cyclist (tracklet 4) at 5 m/s from frame 0, never reported dynamic. A parked
  // van (tracklet 5): no latency.
  std::vector<EvalObject> truth, detections;
  for (int f = 0; f < 10; ++f)
  {
    EvalObject car = object(f, 3, f < 2 ? Motion::kStatic : Motion::kDynamic);
    car.has_state = true;
    car.vx = f < 2 ? 0.0 : f == 2 ? 0.6 : 2.0;
    truth.push_back(car);
    detections.push_back(object(f, 1, f < 6 ? Motion::kStatic : Motion::kDynamic));
    EvalObject cyclist = object(f, 4, Motion::kDynamic, kElsewhere, "cyclist");
    cyclist.has_state = true;
    cyclist.vy = 5.0;
    truth.push_back(cyclist);
    detections.push_back(object(f, 2, Motion::kStatic, kElsewhere, "cyclist"));
    EvalObject van = object(f, 5, Motion::kStatic, BoundingBox{700.F, 100.F, 799.F, 199.F}, "van");
    van.has_state = true;
    truth.push_back(van);
    detections.push_back(object(f, 3, Motion::kStatic, van.box, "van"));
  }
  const TrackingMetrics m = evaluateTracking(truth, detections, TrackingEvaluationConfig{});
  ASSERT_EQ(m.dynamic_latency.size(), 2U);
  EXPECT_EQ(m.dynamic_latency[0].label, "car");
  EXPECT_EQ(m.dynamic_latency[0].track_id, 3);
  EXPECT_NEAR(m.dynamic_latency[0].latency_s, 0.3, 1e-9);
  EXPECT_EQ(m.dynamic_latency[1].label, "cyclist");
  EXPECT_LT(m.dynamic_latency[1].latency_s, 0.0) << "never reported dynamic";

  const LatencyStats all = latencyStats(m.dynamic_latency);
  EXPECT_EQ(all.count, 2U);
  EXPECT_EQ(all.never, 1U);
  EXPECT_NEAR(all.median_s, 0.3, 1e-9);
  EXPECT_TRUE(std::isinf(all.p90_s));
  EXPECT_TRUE(std::isinf(all.worst_s));
  const LatencyStats cars = latencyStats(m.dynamic_latency, "car");
  EXPECT_EQ(cars.count, 1U);
  EXPECT_NEAR(cars.p90_s, 0.3, 1e-9);
  EXPECT_NEAR(cars.worst_s, 0.3, 1e-9);
  EXPECT_EQ(latencyStats(m.dynamic_latency, "van").count, 0U);

  TrackingEvaluationConfig slow;
  slow.latency_speed_mps = 0.5;  // the car counts from frame 2: 0.4 s
  EXPECT_NEAR(evaluateTracking(truth, detections, slow).dynamic_latency.at(0).latency_s, 0.4, 1e-9);
  slow.latency_speed_mps = 0.0;
  EXPECT_THROW(slow.validate(), std::invalid_argument);
}

TEST(TrackingEvaluation, RangeLimitAndDontCareRegions)
{
  // Frame 0: truth 3 at 31 m (beyond the 30 m limit), truth 4 at 20 m. Detections: id 1 on truth
  // 3 from 29 m (ignored: its truth is beyond the limit); id 2 on truth 4 from 30.5 m (a match:
  // the truth is in range); id 5 at 35 m matching nothing (ignored); id 6 in a DontCare region
  // (ignored); id 7 inside the limit matching nothing (a false positive).
  const BoundingBox kNowhere{700.F, 100.F, 799.F, 199.F};
  const BoundingBox kIgnore{900.F, 100.F, 999.F, 199.F};
  EvalObject far = object(0, 3, Motion::kStatic);
  far.longitudinal_m = 31.0;
  EvalObject region = object(0, -1, Motion::kUnknown, kIgnore, "dontcare");
  region.dont_care = true;
  auto at = [](EvalObject o, double longitudinal_m)
  {
    o.longitudinal_m = longitudinal_m;
    return o;
  };
  const std::vector<EvalObject> detections{
      at(object(0, 1, Motion::kStatic), 29.0), at(object(0, 2, Motion::kStatic, kElsewhere), 30.5),
      at(object(0, 5, Motion::kStatic, kNowhere), 35.0), object(0, 6, Motion::kStatic, kIgnore),
      object(0, 7, Motion::kStatic, BoundingBox{0.F, 300.F, 99.F, 399.F})};
  const TrackingMetrics m = evaluateTracking({far, object(0, 4, Motion::kStatic, kElsewhere), region},
                                             detections, TrackingEvaluationConfig{});
  EXPECT_EQ(m.ground_truth, 1U);
  EXPECT_EQ(m.matches, 1U);
  EXPECT_EQ(m.misses, 0U);
  EXPECT_EQ(m.false_positives, 1U);
  EXPECT_EQ(m.truth_tracks, 1U);
  // Identity measures count the matched and the false detection only: IDTP 1, IDFP 1, IDFN 0.
  EXPECT_EQ(m.idtp, 1U);
  EXPECT_EQ(m.idfp, 1U);
  EXPECT_EQ(m.idfn, 0U);
}

TEST(TrackingEvaluation, LabelsAndRangeAndConfig)
{
  EvalObject far = object(0, 3, Motion::kStatic);
  far.longitudinal_m = 45.0;
  const TrackingMetrics m =
      evaluateTracking({far, object(0, 4, Motion::kStatic, kElsewhere)},
                       {object(0, 1, Motion::kStatic, kElsewhere, "van")}, TrackingEvaluationConfig{});
  EXPECT_EQ(m.ground_truth, 1U);  // the far car is out of range
  EXPECT_EQ(m.matches, 0U);       // a van does not match a car
  EXPECT_EQ(m.false_positives, 1U);
  EXPECT_EQ(m.mostly_lost, 1U);
  TrackingEvaluationConfig bad;
  bad.flicker_window_s = 0.0;
  EXPECT_THROW(evaluateTracking({}, {}, bad), std::invalid_argument);
}

}  // namespace grid_vision_fusion
