// Unit tests of the evaluation: IoU, VOC AP and the Cartucho/mAP matching rules on small cases
// computed by hand, and a 3-frame regression case with every figure worked out in comments.
#include <gtest/gtest.h>

#include <cmath>

#include "grid_vision_fusion/evaluation/evaluation.h"

namespace grid_vision_fusion
{
namespace
{
EvalObject object(const std::string& frame, const std::string& label, Motion motion, BoundingBox box,
                  float score = 1.F)
{
  EvalObject o;
  o.frame = frame;
  o.label = label;
  o.motion = motion;
  o.box = box;
  o.score = score;
  o.longitudinal_m = 10.0;
  return o;
}

EvalObject withState(EvalObject o, double x, double y, double vx, double vy)
{
  o.has_state = true;
  o.x = x;
  o.y = y;
  o.vx = vx;
  o.vy = vy;
  return o;
}

const BoundingBox kA{0.F, 0.F, 9.F, 9.F};  // 10 x 10 pixels with the +1 convention
const BoundingBox kFar{20.F, 20.F, 29.F, 29.F};

EvaluationConfig perClass()
{
  EvaluationConfig config;
  config.motion_classes = false;
  return config;
}

const ClassMetrics& find(const EvaluationResult& result, const std::string& name)
{
  for (const auto& m : result.classes)
  {
    if (m.name == name)
    {
      return m;
    }
  }
  throw std::runtime_error("no class " + name);
}
}  // namespace

TEST(Evaluation, IouWithThePlusOneConvention)
{
  EXPECT_DOUBLE_EQ(boxIou(kA, kA), 1.0);
  EXPECT_DOUBLE_EQ(boxIou(kA, kFar), 0.0);
  // (0..9) vs (5..14) in x, same rows: overlap 5 x 10 = 50, union 100 + 100 − 50 = 150.
  EXPECT_DOUBLE_EQ(boxIou(kA, BoundingBox{5.F, 0.F, 14.F, 9.F}), 50.0 / 150.0);
  // Touching on one pixel column (x = 9): 1 x 10 = 10, union 190.
  EXPECT_DOUBLE_EQ(boxIou(kA, BoundingBox{9.F, 0.F, 18.F, 9.F}), 10.0 / 190.0);
}

TEST(Evaluation, VocApAllPointInterpolation)
{
  EXPECT_DOUBLE_EQ(vocAveragePrecision({}, {}), 0.0);
  EXPECT_DOUBLE_EQ(vocAveragePrecision({1.0}, {1.0}), 1.0);
  // TP FP FP TP of 2 ground truths: rec .5 .5 .5 1, prec 1 .5 1/3 .5 → .5·1 + .5·.5 = .75.
  EXPECT_DOUBLE_EQ(vocAveragePrecision({0.5, 0.5, 0.5, 1.0}, {1.0, 0.5, 1.0 / 3.0, 0.5}), 0.75);
  EXPECT_THROW(vocAveragePrecision({0.5}, {}), std::invalid_argument);
}

TEST(Evaluation, DuplicatesAreFalsePositives)
{
  const std::vector<EvalObject> gt{object("a", "car", Motion::kStatic, kA),
                                   object("b", "car", Motion::kStatic, kA)};
  const std::vector<EvalObject> det{object("a", "car", Motion::kStatic, kA, 0.9F),
                                    object("a", "car", Motion::kStatic, kA, 0.8F),    // duplicate: FP
                                    object("b", "car", Motion::kStatic, kFar, 0.8F),  // no overlap: FP
                                    object("b", "car", Motion::kStatic, kA, 0.7F)};
  const EvaluationResult r = evaluate(gt, det, perClass());
  ASSERT_EQ(r.classes.size(), 1U);
  const ClassMetrics& car = r.classes[0];
  EXPECT_EQ(car.name, "car");
  EXPECT_EQ(car.ground_truth, 2U);
  EXPECT_EQ(car.true_positives, 2U);
  EXPECT_EQ(car.false_positives, 2U);
  EXPECT_DOUBLE_EQ(car.average_precision, 0.75);
  EXPECT_DOUBLE_EQ(car.precision, 0.5);
  EXPECT_DOUBLE_EQ(car.recall, 1.0);
  EXPECT_NEAR(car.f1, 2.0 / 3.0, 1e-12);
  EXPECT_DOUBLE_EQ(r.mean_average_precision, 0.75);
}

TEST(Evaluation, TiesKeepTheInputOrder)
{
  const std::vector<EvalObject> gt{object("a", "car", Motion::kStatic, kA),
                                   object("b", "car", Motion::kStatic, kA)};
  const EvalObject miss = object("a", "car", Motion::kStatic, kFar, 0.9F);
  const EvalObject hit = object("b", "car", Motion::kStatic, kA, 0.9F);
  // FP then TP: rec 0 .5, prec 0 .5 → AP = .5·.5 = .25.
  EXPECT_DOUBLE_EQ(evaluate(gt, {miss, hit}, perClass()).classes[0].average_precision, 0.25);
  // TP then FP: rec .5 .5, prec 1 .5 → AP = .5·1 = .5.
  EXPECT_DOUBLE_EQ(evaluate(gt, {hit, miss}, perClass()).classes[0].average_precision, 0.5);
}

TEST(Evaluation, DifficultGroundTruthIsIgnored)
{
  EvalObject hard = object("a", "car", Motion::kStatic, kA);
  hard.difficult = true;
  const std::vector<EvalObject> gt{hard, object("b", "car", Motion::kStatic, kA)};
  const std::vector<EvalObject> det{object("a", "car", Motion::kStatic, kA, 0.9F),  // on the difficult one
                                    object("b", "car", Motion::kStatic, kA, 0.5F)};
  const ClassMetrics car = evaluate(gt, det, perClass()).classes.at(0);
  EXPECT_EQ(car.ground_truth, 1U);
  EXPECT_EQ(car.detections, 1U);
  EXPECT_EQ(car.true_positives, 1U);
  EXPECT_EQ(car.false_positives, 0U);
  EXPECT_DOUBLE_EQ(car.average_precision, 1.0);
  EXPECT_DOUBLE_EQ(car.precision, 1.0);
}

TEST(Evaluation, NoFallbackToTheSecondBestMatch)
{
  // g1 = (0..9), g2 = (3..12). d1 = g1 exactly → TP. d2 = (1..10): IoU .818 with g1 (used),
  // .667 with g2: it takes g1 and is a FP although g2 would have matched.
  const std::vector<EvalObject> gt{object("a", "car", Motion::kStatic, kA),
                                   object("a", "car", Motion::kStatic, BoundingBox{3.F, 0.F, 12.F, 9.F})};
  const std::vector<EvalObject> det{
      object("a", "car", Motion::kStatic, kA, 0.9F),
      object("a", "car", Motion::kStatic, BoundingBox{1.F, 0.F, 10.F, 9.F}, 0.8F)};
  const ClassMetrics car = evaluate(gt, det, perClass()).classes.at(0);
  EXPECT_EQ(car.true_positives, 1U);
  EXPECT_EQ(car.false_positives, 1U);
  EXPECT_DOUBLE_EQ(car.average_precision, 0.5);  // rec .5 .5, prec 1 .5
}

TEST(Evaluation, ClassWithoutDetectionsCountsZeroInTheMap)
{
  const std::vector<EvalObject> gt{object("a", "car", Motion::kDynamic, kA),
                                   object("a", "van", Motion::kStatic, kFar)};
  const std::vector<EvalObject> det{object("a", "car", Motion::kDynamic, kA, 0.9F),
                                    object("a", "truck", Motion::kStatic, kA, 0.9F)};  // class not in the GT
  const EvaluationResult r = evaluate(gt, det, EvaluationConfig{});
  EXPECT_DOUBLE_EQ(find(r, "dynamicCar").average_precision, 1.0);
  EXPECT_DOUBLE_EQ(find(r, "staticVan").average_precision, 0.0);
  EXPECT_EQ(find(r, "staticVan").ground_truth, 1U);
  EXPECT_EQ(find(r, "staticTruck").false_positives, 1U);
  EXPECT_DOUBLE_EQ(r.mean_average_precision, 0.5);  // (1 + 0) / 2: staticTruck is not a GT class
  EXPECT_EQ(r.classes.back().name, "staticTruck");  // GT classes listed first
}

TEST(Evaluation, RangeLimitIgnoresFarTruthAndLeavesOutFarFalsePositives)
{
  // Truth: g1 at 10 m (kA), g2 at 31 m (kFar), beyond the 30 m limit. Detections, by score:
  // d1 inside (29.5 m) on g2: ignored (before: a false positive); d2 beyond (30.5 m) on g1: a
  // true positive (before: left out, g1 missed); d3 beyond (31 m) matching nothing: left out;
  // d4 inside matching nothing: a false positive. g2 is never a miss.
  EvalObject g2 = object("a", "car", Motion::kStatic, kFar);
  g2.longitudinal_m = 31.0;
  const std::vector<EvalObject> gt{object("a", "car", Motion::kStatic, kA), g2};
  auto at = [](EvalObject o, double longitudinal_m)
  {
    o.longitudinal_m = longitudinal_m;
    return o;
  };
  const BoundingBox kNowhere{50.F, 50.F, 59.F, 59.F};
  const std::vector<EvalObject> det{at(object("a", "car", Motion::kStatic, kFar, 0.9F), 29.5),
                                    at(object("a", "car", Motion::kStatic, kA, 0.8F), 30.5),
                                    at(object("a", "car", Motion::kStatic, kNowhere, 0.7F), 31.0),
                                    at(object("a", "car", Motion::kStatic, kNowhere, 0.6F), 20.0)};
  const EvaluationResult r = evaluate(gt, det, perClass());
  ASSERT_EQ(r.classes.size(), 1U);
  const ClassMetrics& car = r.classes[0];
  EXPECT_EQ(car.ground_truth, 1U);
  EXPECT_EQ(car.detections, 2U);
  EXPECT_EQ(car.true_positives, 1U);
  EXPECT_EQ(car.false_positives, 1U);
  EXPECT_EQ(car.ignored_beyond_range, 1U);
  EXPECT_EQ(car.left_out_beyond_range, 1U);
  EXPECT_EQ(car.ignored_difficult, 0U);
  EXPECT_DOUBLE_EQ(car.recall, 1.0);
  EXPECT_DOUBLE_EQ(car.average_precision, 1.0);  // d2 TP (rec 1, prec 1), then d4 FP
  EXPECT_EQ(detectionOutcomes(gt, det, perClass()),
            (std::vector<DetectionOutcome>{
                DetectionOutcome::kIgnoredBeyondRange, DetectionOutcome::kTruePositive,
                DetectionOutcome::kLeftOutBeyondRange, DetectionOutcome::kFalsePositive}));
  // The motion figures take the true positive whose detection lies beyond the limit.
  ASSERT_EQ(r.matched_objects.size(), 1U);
  EXPECT_EQ(r.motion_confusion[1][1], 1U);
  EXPECT_DOUBLE_EQ(r.matched_objects[0].longitudinal_m, 10.0);

  // A detection inside the limit whose truth lies at 31 m alone: ignored, no false positive; the
  // class has no counted truth (not in the mAP).
  const EvaluationResult only_far = evaluate({g2}, {det[0]}, perClass());
  ASSERT_EQ(only_far.classes.size(), 1U);
  EXPECT_EQ(only_far.classes[0].false_positives, 0U);
  EXPECT_EQ(only_far.classes[0].ignored_beyond_range, 1U);
  EXPECT_EQ(only_far.classes[0].ground_truth, 0U);
  // Far detections matching nothing, alone: no class at all (as they were left out before).
  EXPECT_TRUE(evaluate({}, {det[2]}, perClass()).classes.empty());

  // With a 40 m limit everything is in range: g2 counts, d1 is its true positive, d3 a false one.
  EvaluationConfig wide = perClass();
  wide.max_longitudinal_m = 40.0;
  const ClassMetrics all = evaluate(gt, det, wide).classes.at(0);
  EXPECT_EQ(all.ground_truth, 2U);
  EXPECT_EQ(all.true_positives, 2U);
  EXPECT_EQ(all.false_positives, 2U);
}

TEST(Evaluation, UnscoredTruthTakesItsDetectionsWhateverTheirMotion)
{
  // Two cars nobody scores: a static one at 31 m (beyond the limit), one of unknown motion
  // (difficult: too short a track to tell). A detection of each reporting a motion they do not
  // have is ignored (before: a false positive of its motion class). A difficult car of known
  // motion keeps the paper's rule: a detection of it with the other motion is a false positive of
  // that class; so is a wrong motion on a counted car (which is missed too).
  const BoundingBox b{30.F, 0.F, 39.F, 9.F}, c{60.F, 0.F, 69.F, 9.F};
  EvalObject difficult = object("a", "car", Motion::kStatic, kA);
  difficult.difficult = true;
  EvalObject beyond = object("a", "car", Motion::kStatic, b);
  beyond.longitudinal_m = 31.0;
  EvalObject unknown = object("a", "car", Motion::kUnknown, c);
  unknown.difficult = true;
  const std::vector<EvalObject> gt{difficult, beyond, unknown, object("b", "car", Motion::kStatic, kA)};
  const std::vector<EvalObject> det{
      object("a", "car", Motion::kDynamic, kA, 0.9F), object("a", "car", Motion::kDynamic, b, 0.8F),
      object("a", "car", Motion::kStatic, c, 0.7F), object("b", "car", Motion::kDynamic, kA, 0.6F)};
  EXPECT_EQ(
      detectionOutcomes(gt, det, EvaluationConfig{}),
      (std::vector<DetectionOutcome>{DetectionOutcome::kFalsePositive, DetectionOutcome::kIgnoredBeyondRange,
                                     DetectionOutcome::kIgnoredDifficult, DetectionOutcome::kFalsePositive}));
  const EvaluationResult r = evaluate(gt, det, EvaluationConfig{});
  EXPECT_EQ(find(r, "dynamicCar").false_positives, 2U);
  EXPECT_EQ(find(r, "dynamicCar").ignored_beyond_range, 1U);
  EXPECT_EQ(find(r, "dynamicCar").ground_truth, 0U);
  EXPECT_EQ(find(r, "staticCar").ground_truth, 1U);  // the counted car, missed
  EXPECT_EQ(find(r, "staticCar").false_positives, 0U);
  EXPECT_EQ(find(r, "staticCar").ignored_difficult, 1U);
  // Per class only, as before: three ignored, the fourth a true positive.
  const ClassMetrics car = evaluate(gt, det, perClass()).classes.at(0);
  EXPECT_EQ(car.true_positives, 1U);
  EXPECT_EQ(car.ignored_difficult + car.ignored_beyond_range, 3U);
  EXPECT_EQ(truthClasses(beyond, EvaluationConfig{}),
            (std::vector<std::string>{"staticCar", "unknownCar", "dynamicCar"}));
  EXPECT_EQ(truthClasses(unknown, EvaluationConfig{}),
            (std::vector<std::string>{"unknownCar", "staticCar", "dynamicCar"}));
  EXPECT_EQ(truthClasses(difficult, EvaluationConfig{}), (std::vector<std::string>{"staticCar"}));
  EXPECT_EQ(truthClasses(gt[3], EvaluationConfig{}), (std::vector<std::string>{"staticCar"}));
  EXPECT_EQ(truthClasses(beyond, perClass()), (std::vector<std::string>{"car"}));
}

TEST(Evaluation, DontCareRegionsIgnoreFalsePositivesInThem)
{
  // A DontCare region R = (100..199)² in frame a, another over the car kA. Detections: d1 on the
  // car (TP); d2 a duplicate of d1 (would be FP; inside the second region: ignored); d3 inside R
  // (intersection / its area = 1: ignored); d4 a quarter inside R (0.25 < 0.5: FP); d5 inside R
  // but in frame b (FP). The regions' label and motion play no part.
  EvalObject region = object("a", "dontcare", Motion::kUnknown, BoundingBox{100.F, 100.F, 199.F, 199.F});
  region.dont_care = true;
  EvalObject over_car = object("a", "whatever", Motion::kUnknown, BoundingBox{0.F, 0.F, 20.F, 20.F});
  over_car.dont_care = true;
  const std::vector<EvalObject> gt{object("a", "car", Motion::kStatic, kA), region, over_car};
  const std::vector<EvalObject> det{
      object("a", "car", Motion::kStatic, kA, 0.9F), object("a", "car", Motion::kStatic, kA, 0.8F),
      object("a", "car", Motion::kStatic, BoundingBox{110.F, 110.F, 189.F, 189.F}, 0.7F),
      object("a", "car", Motion::kStatic, BoundingBox{150.F, 150.F, 249.F, 249.F}, 0.6F),
      object("b", "car", Motion::kStatic, BoundingBox{110.F, 110.F, 189.F, 189.F}, 0.5F)};
  const EvaluationResult r = evaluate(gt, det, perClass());
  ASSERT_EQ(r.classes.size(), 1U);  // the regions are no class
  const ClassMetrics& car = r.classes[0];
  EXPECT_EQ(car.ground_truth, 1U);
  EXPECT_EQ(car.true_positives, 1U);
  EXPECT_EQ(car.false_positives, 2U);
  EXPECT_EQ(car.ignored_dont_care, 2U);
  EXPECT_EQ(
      detectionOutcomes(gt, det, perClass()),
      (std::vector<DetectionOutcome>{DetectionOutcome::kTruePositive, DetectionOutcome::kIgnoredDontCare,
                                     DetectionOutcome::kIgnoredDontCare, DetectionOutcome::kFalsePositive,
                                     DetectionOutcome::kFalsePositive}));
  EXPECT_EQ(r.matched_objects.size(), 1U);
  EXPECT_EQ(toString(DetectionOutcome::kIgnoredDontCare), "ignored_dont_care");
}

TEST(Evaluation, ErrorStatsQuantiles)
{
  const ErrorStats s = errorStats({1.0, 0.0, 0.0, 0.5, 0.0});
  EXPECT_EQ(s.count, 5U);
  EXPECT_DOUBLE_EQ(s.median, 0.0);
  EXPECT_DOUBLE_EQ(s.mean, 0.3);
  EXPECT_DOUBLE_EQ(s.p90, 0.8);  // rank 3.6 between 0.5 and 1.0
  EXPECT_EQ(errorStats({}).count, 0U);
}

TEST(Evaluation, ConfigValidation)
{
  EvaluationConfig config;
  config.iou_threshold = 0.0;
  EXPECT_THROW(config.validate(), std::invalid_argument);
  config = EvaluationConfig{};
  config.max_longitudinal_m = -1.0;
  EXPECT_THROW(evaluate({}, {}, config), std::invalid_argument);
  EXPECT_EQ(evaluationClass("car", Motion::kDynamic, true), "dynamicCar");
  EXPECT_EQ(evaluationClass("van", Motion::kStatic, false), "van");
}

// Three frames, four GT classes; every figure below is worked out by hand.
TEST(Evaluation, ThreeFrameRegression)
{
  const BoundingBox left{100.F, 100.F, 199.F, 199.F};
  const BoundingBox right{300.F, 100.F, 399.F, 199.F};
  const BoundingBox empty_road{500.F, 100.F, 599.F, 199.F};
  const std::vector<EvalObject> gt{
      withState(object("f0", "car", Motion::kDynamic, left), 10.0, 0.0, 5.0, 0.0),   // g1
      withState(object("f0", "car", Motion::kStatic, right), 15.0, 5.0, 0.0, 0.0),   // g2
      withState(object("f1", "car", Motion::kDynamic, left), 10.5, 0.0, 5.0, 0.0),   // g3
      withState(object("f1", "van", Motion::kStatic, right), 20.0, -3.0, 0.0, 0.0),  // g4
      withState(object("f2", "van", Motion::kDynamic, left), 12.0, 1.0, 0.0, 4.0)};  // g5
  const std::vector<EvalObject> det{
      withState(object("f0", "car", Motion::kDynamic, left, 0.9F), 10.4, 0.3, 4.0, 0.0),  // d1 → g1
      withState(object("f0", "car", Motion::kDynamic, right, 0.6F), 15.0, 5.0, 1.0,
                1.0),  // d2 → g2, wrong motion
      withState(object("f1", "car", Motion::kDynamic, left, 0.8F), 10.5, 0.0, 0.0, 5.0),   // d3 → g3
      withState(object("f1", "van", Motion::kStatic, right, 0.7F), 20.0, -2.0, 0.0, 0.0),  // d4 → g4
      withState(object("f2", "van", Motion::kStatic, left, 0.5F), 12.0, 1.0, 0.0,
                0.0),  // d5 → g5, wrong motion
      withState(object("f2", "car", Motion::kStatic, empty_road, 0.4F), 30.0, 0.0, 0.0, 0.0)};  // d6: FP
  const EvaluationResult r = evaluate(gt, det, EvaluationConfig{});

  // dynamicCar: d1 TP, d3 TP, d2 FP (no dynamic car on the right) → rec .5 1 1, prec 1 1 2/3.
  const ClassMetrics& dyn_car = find(r, "dynamicCar");
  EXPECT_EQ(dyn_car.ground_truth, 2U);
  EXPECT_EQ(dyn_car.true_positives, 2U);
  EXPECT_EQ(dyn_car.false_positives, 1U);
  EXPECT_DOUBLE_EQ(dyn_car.average_precision, 1.0);
  EXPECT_NEAR(dyn_car.precision, 2.0 / 3.0, 1e-12);
  EXPECT_DOUBLE_EQ(dyn_car.recall, 1.0);
  EXPECT_NEAR(dyn_car.f1, 0.8, 1e-12);
  // staticCar: d6 FP, g2 missed.
  const ClassMetrics& st_car = find(r, "staticCar");
  EXPECT_EQ(st_car.false_positives, 1U);
  EXPECT_DOUBLE_EQ(st_car.average_precision, 0.0);
  EXPECT_DOUBLE_EQ(st_car.f1, 0.0);
  // staticVan: d4 TP, d5 FP → rec 1 1, prec 1 .5 → AP 1, P .5, R 1, F1 2/3.
  const ClassMetrics& st_van = find(r, "staticVan");
  EXPECT_DOUBLE_EQ(st_van.average_precision, 1.0);
  EXPECT_DOUBLE_EQ(st_van.precision, 0.5);
  EXPECT_DOUBLE_EQ(st_van.recall, 1.0);
  EXPECT_NEAR(st_van.f1, 2.0 / 3.0, 1e-12);
  // dynamicVan: g5 never found.
  const ClassMetrics& dyn_van = find(r, "dynamicVan");
  EXPECT_EQ(dyn_van.detections, 0U);
  EXPECT_DOUBLE_EQ(dyn_van.recall, 0.0);
  EXPECT_DOUBLE_EQ(r.mean_average_precision, 0.5);  // (1 + 0 + 1 + 0) / 4
  EXPECT_EQ(r.classes.size(), 4U);

  // Matching by class alone: d1-g1, d3-g3, d2-g2 (cars), d4-g4, d5-g5 (vans); d6 unmatched.
  const auto kU = static_cast<std::size_t>(Motion::kUnknown);
  const auto kS = static_cast<std::size_t>(Motion::kStatic);
  const auto kD = static_cast<std::size_t>(Motion::kDynamic);
  EXPECT_EQ(r.motion_confusion[kD][kD], 2U);
  EXPECT_EQ(r.motion_confusion[kS][kD], 1U);
  EXPECT_EQ(r.motion_confusion[kS][kS], 1U);
  EXPECT_EQ(r.motion_confusion[kD][kS], 1U);
  EXPECT_EQ(r.motion_confusion[kU][kU], 0U);
  // Position errors .5 0 0 1 0 → median 0, mean .3, p90 .8.
  EXPECT_EQ(r.position_error_m.count, 5U);
  EXPECT_NEAR(r.position_error_m.median, 0.0, 1e-12);
  EXPECT_NEAR(r.position_error_m.mean, 0.3, 1e-12);
  EXPECT_NEAR(r.position_error_m.p90, 0.8, 1e-12);
  // Speed errors 1 0 √2 0 4 → sorted 0 0 1 √2 4: median 1, mean (5 + √2)/5, p90 √2 + .6(4 − √2).
  EXPECT_NEAR(r.speed_error_mps.median, 1.0, 1e-12);
  EXPECT_NEAR(r.speed_error_mps.mean, (5.0 + std::sqrt(2.0)) / 5.0, 1e-12);
  EXPECT_NEAR(r.speed_error_mps.p90, std::sqrt(2.0) + 0.6 * (4.0 - std::sqrt(2.0)), 1e-12);
  // Heading errors, both dynamic only: d1 0, d3 π/2 → median π/4, p90 .9·π/2.
  EXPECT_EQ(r.heading_error_rad.count, 2U);
  EXPECT_NEAR(r.heading_error_rad.median, M_PI / 4.0, 1e-12);
  EXPECT_NEAR(r.heading_error_rad.p90, 0.9 * M_PI / 2.0, 1e-12);
}

TEST(Evaluation, SpeedBands)
{
  EXPECT_EQ(speedBandOf(Motion::kStatic, true, 0.2), SpeedBand::kStatic);
  EXPECT_EQ(speedBandOf(Motion::kStatic, false, 0.0), SpeedBand::kStatic);
  EXPECT_EQ(speedBandOf(Motion::kDynamic, true, 0.5), SpeedBand::kBelow1);
  EXPECT_EQ(speedBandOf(Motion::kDynamic, true, 0.99), SpeedBand::kBelow1);
  EXPECT_EQ(speedBandOf(Motion::kDynamic, true, 1.0), SpeedBand::k1To3);
  EXPECT_EQ(speedBandOf(Motion::kDynamic, true, 2.99), SpeedBand::k1To3);
  EXPECT_EQ(speedBandOf(Motion::kDynamic, true, 3.0), SpeedBand::kAbove3);
  EXPECT_EQ(speedBandOf(Motion::kDynamic, false, 5.0), SpeedBand::kUnknown);  // no velocity
  EXPECT_EQ(speedBandOf(Motion::kDynamic, true, std::nan("")), SpeedBand::kUnknown);
  EXPECT_EQ(speedBandOf(Motion::kUnknown, true, 5.0), SpeedBand::kUnknown);
  EXPECT_EQ(toString(SpeedBand::kStatic), "static");
  EXPECT_EQ(toString(SpeedBand::kBelow1), "0.5-1");
  EXPECT_EQ(toString(SpeedBand::k1To3), "1-3");
  EXPECT_EQ(toString(SpeedBand::kAbove3), ">3");
  EXPECT_EQ(toString(SpeedBand::kUnknown), "unknown");
}

// One object per frame, so every detection matches the ground truth of its frame.
TEST(Evaluation, MatchedObjectsPerClassAndSpeedBand)
{
  const std::vector<EvalObject> gt{
      withState(object("f0", "car", Motion::kStatic, kA), 10.0, 0.0, 0.0, 0.0),
      withState(object("f1", "car", Motion::kDynamic, kA), 10.0, 0.0, 0.0, 0.8),  // 0.5-1
      withState(object("f2", "car", Motion::kDynamic, kA), 10.0, 0.0, 2.0, 0.0),  // 1-3
      withState(object("f3", "car", Motion::kDynamic, kA), 10.0, 0.0, 3.0, 4.0),  // >3 (5 m/s)
      withState(object("f4", "pedestrian", Motion::kDynamic, kA), 5.0, 1.0, 1.2, 0.0),
      object("f5", "pedestrian", Motion::kDynamic, kA),  // no state: band unknown, no errors
      withState(object("f6", "car", Motion::kDynamic, kA), 10.0, 0.0, 6.0, 0.0),  // not detected
  };
  const std::vector<EvalObject> det{
      withState(object("f0", "car", Motion::kStatic, kA), 11.0, 0.0, 0.0, 0.0),
      withState(object("f1", "car", Motion::kStatic, kA), 10.0, 0.0, 0.0, 0.0),
      withState(object("f2", "car", Motion::kDynamic, kA), 10.0, 0.5, 0.0, 2.5),
      withState(object("f3", "car", Motion::kUnknown, kA), 10.0, 0.0, 0.0, 0.0),
      withState(object("f4", "pedestrian", Motion::kDynamic, kA), 5.0, 1.0, 1.0, 0.0),
      withState(object("f5", "pedestrian", Motion::kStatic, kA), 5.0, 1.0, 0.0, 0.0),
  };
  const EvaluationResult r = evaluate(gt, det, perClass());
  ASSERT_EQ(r.matched_objects.size(), 6U);
  // Classes by name (car before pedestrian), detections by score (all 1: input order).
  const MatchedObject& slow = r.matched_objects[1];
  EXPECT_EQ(slow.frame, "f1");
  EXPECT_EQ(slow.label, "car");
  EXPECT_EQ(slow.truth_motion, Motion::kDynamic);
  EXPECT_EQ(slow.predicted_motion, Motion::kStatic);
  EXPECT_EQ(slow.band, SpeedBand::kBelow1);
  EXPECT_DOUBLE_EQ(slow.truth_speed_mps, 0.8);
  EXPECT_DOUBLE_EQ(slow.longitudinal_m, 10.0);
  EXPECT_TRUE(slow.has_state);
  EXPECT_DOUBLE_EQ(slow.speed_error_mps, 0.8);
  EXPECT_TRUE(std::isnan(slow.heading_error_rad));  // predicted static: no heading
  const MatchedObject& medium = r.matched_objects[2];
  EXPECT_EQ(medium.band, SpeedBand::k1To3);
  EXPECT_DOUBLE_EQ(medium.position_error_m, 0.5);
  EXPECT_DOUBLE_EQ(medium.speed_error_mps, 0.5);
  EXPECT_NEAR(medium.heading_error_rad, M_PI / 2.0, 1e-12);
  EXPECT_EQ(r.matched_objects[3].band, SpeedBand::kAbove3);
  EXPECT_DOUBLE_EQ(r.matched_objects[3].truth_speed_mps, 5.0);
  const MatchedObject& no_state = r.matched_objects[5];
  EXPECT_EQ(no_state.label, "pedestrian");
  EXPECT_EQ(no_state.band, SpeedBand::kUnknown);
  EXPECT_FALSE(no_state.has_state);
  EXPECT_TRUE(std::isnan(no_state.position_error_m));

  const auto kU = static_cast<std::size_t>(Motion::kUnknown);
  const auto kS = static_cast<std::size_t>(Motion::kStatic);
  const auto kD = static_cast<std::size_t>(Motion::kDynamic);
  ASSERT_EQ(r.motion_confusion_by_class.size(), 2U);
  const auto& car = r.motion_confusion_by_class.at("car");
  EXPECT_EQ(car[kS][kS], 1U);
  EXPECT_EQ(car[kD][kS], 1U);
  EXPECT_EQ(car[kD][kD], 1U);
  EXPECT_EQ(car[kD][kU], 1U);
  const auto& pedestrian = r.motion_confusion_by_class.at("pedestrian");
  EXPECT_EQ(pedestrian[kD][kD], 1U);
  EXPECT_EQ(pedestrian[kD][kS], 1U);
  // The per-class matrices add up to the overall one.
  for (std::size_t t = 0; t < 3; ++t)
  {
    for (std::size_t p = 0; p < 3; ++p)
    {
      EXPECT_EQ(car[t][p] + pedestrian[t][p], r.motion_confusion[t][p]) << t << " " << p;
    }
  }
  const auto& car_bands = r.motion_by_class_and_band.at("car");
  EXPECT_EQ(car_bands.at(SpeedBand::kStatic), (MotionCounts{0, 1, 0}));
  EXPECT_EQ(car_bands.at(SpeedBand::kBelow1), (MotionCounts{0, 1, 0}));
  EXPECT_EQ(car_bands.at(SpeedBand::k1To3), (MotionCounts{0, 0, 1}));
  EXPECT_EQ(car_bands.at(SpeedBand::kAbove3), (MotionCounts{1, 0, 0}));
  EXPECT_EQ(car_bands.count(SpeedBand::kUnknown), 0U);
  const auto& pedestrian_bands = r.motion_by_class_and_band.at("pedestrian");
  EXPECT_EQ(pedestrian_bands.at(SpeedBand::k1To3), (MotionCounts{0, 0, 1}));
  EXPECT_EQ(pedestrian_bands.at(SpeedBand::kUnknown), (MotionCounts{0, 1, 0}));
  // The overall error statistics are those of the matches with a state.
  EXPECT_EQ(r.position_error_m.count, 5U);
  EXPECT_EQ(r.heading_error_rad.count, 2U);  // f2 and f4
}

}  // namespace grid_vision_fusion
