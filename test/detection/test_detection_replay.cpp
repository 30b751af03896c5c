// DetectionReplay: frame indices, file names, class mapping, scores, clipping, errors; the
// detector noise drawn on the labels (detection_noise.h): off = the oracle boxes, seeded and
// history-free, each component's statistics over many draws against its parameters, errors
// naming the key; the normal quantile of its truncated draws (normal_quantile.h).
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <map>
#include <numeric>
#include <tuple>

#include "grid_vision_fusion/detection/detection_replay.h"
#include "grid_vision_fusion/normal_quantile.h"

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

// ---- the detector noise ------------------------------------------------------------------------

/// Every component off: switch on the ones a test measures.
DetectionNoiseConfig quietNoise()
{
  DetectionNoiseConfig c;
  c.enabled = true;
  c.misses = c.box_jitter = c.partial_boxes = c.confusion = c.extra_boxes = c.false_positives = false;
  return c;
}

NoiseLabel noiseLabel(const std::string& label, BoundingBox box, int occluded = 0, float truncated = 0.F,
                      std::size_t line = 0)
{
  NoiseLabel in;
  in.detection.label = label;
  in.detection.class_id = noiseClassId(label);
  in.detection.score = 1.F;
  in.detection.box = box;
  in.occluded = occluded;
  in.truncated = truncated;
  in.line = line;
  return in;
}

double sigmoidOf(double x)
{
  return 1.0 / (1.0 + std::exp(-x));
}

struct Moments
{
  std::vector<double> values;
  double mean() const { return std::accumulate(values.begin(), values.end(), 0.0) / values.size(); }
  double sd() const
  {
    const double m = mean();
    double sum = 0.0;
    for (double v : values)
    {
      sum += (v - m) * (v - m);
    }
    return std::sqrt(sum / (values.size() - 1));
  }
};

constexpr int kDraws = 20000;
const BoundingBox kCarBox{500.F, 150.F, 700.F, 250.F};  // 100 px high, well inside 1242 x 375

TEST(DetectionNoiseTest, DisabledReplaysTheOracleBoxesExactly)
{
  DetectionReplayConfig oracle = groundTruthConfig();
  DetectionReplayConfig off = oracle;
  off.noise.seed = 7;  // every magnitude at its calibrated default, but enabled false
  for (std::int64_t frame = 0; frame < 3; ++frame)
  {
    const auto a = DetectionReplay(oracle).detectionsOf(frame, 1242, 375);
    const auto b = DetectionReplay(off).detectionsOf(frame, 1242, 375);
    ASSERT_EQ(a.size(), b.size());
    for (std::size_t i = 0; i < a.size(); ++i)
    {
      EXPECT_EQ(a[i].label, b[i].label);
      EXPECT_EQ(a[i].class_id, b[i].class_id);
      EXPECT_EQ(a[i].score, b[i].score);
      EXPECT_EQ(a[i].box.x_min, b[i].box.x_min);
      EXPECT_EQ(a[i].box.y_min, b[i].box.y_min);
      EXPECT_EQ(a[i].box.x_max, b[i].box.x_max);
      EXPECT_EQ(a[i].box.y_max, b[i].box.y_max);
    }
  }
  // Enabled with every component off: the same boxes too (in order of score, all 1).
  DetectionReplayConfig quiet = oracle;
  quiet.noise = quietNoise();
  const auto a = DetectionReplay(oracle).detectionsOf(1, 1242, 375);
  const auto b = DetectionReplay(quiet).detectionsOf(1, 1242, 375);
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t i = 0; i < a.size(); ++i)
  {
    EXPECT_EQ(a[i].label, b[i].label);
    EXPECT_EQ(a[i].box.y_max, b[i].box.y_max);
  }
}

TEST(DetectionNoiseTest, SeededAndFreeOfHistory)
{
  DetectionReplayConfig config = groundTruthConfig();
  config.noise.enabled = true;
  config.noise.seed = 11;
  config.score_threshold = 0.0;
  const auto same = [](const std::vector<Detection>& a, const std::vector<Detection>& b)
  {
    if (a.size() != b.size())
    {
      return false;
    }
    for (std::size_t i = 0; i < a.size(); ++i)
    {
      if (a[i].label != b[i].label || a[i].score != b[i].score || a[i].box.x_min != b[i].box.x_min ||
          a[i].box.y_max != b[i].box.y_max)
      {
        return false;
      }
    }
    return true;
  };
  DetectionReplay fresh(config);
  DetectionReplay used(config);
  used.detectionsOf(0, 1242, 375);
  used.detectionsOf(2, 1242, 375);
  EXPECT_TRUE(same(fresh.detectionsOf(1, 1242, 375), used.detectionsOf(1, 1242, 375)))
      << "a frame's noise depends on its index only, not on what was replayed before";
  EXPECT_TRUE(same(fresh.detectionsOf(1, 1242, 375), fresh.detectionsOf(1, 1242, 375)));
  // Another seed or another frame index (the same labels): other noise.
  DetectionReplayConfig other_seed = config;
  other_seed.noise.seed = 12;
  const std::vector<NoiseLabel> labels{noiseLabel("car", kCarBox)};
  int differ_seed = 0;
  int differ_frame = 0;
  for (std::int64_t frame = 0; frame < 20; ++frame)
  {
    const auto a = applyDetectionNoise(config.noise, frame, labels, 1242, 375);
    differ_seed += !same(a, applyDetectionNoise(other_seed.noise, frame, labels, 1242, 375));
    differ_frame += !same(a, applyDetectionNoise(config.noise, frame + 1, labels, 1242, 375));
  }
  EXPECT_EQ(differ_seed, 20);
  EXPECT_EQ(differ_frame, 20);
  EXPECT_NE(fresh.description().find("noise seed 11"), std::string::npos) << fresh.description();
}

TEST(DetectionNoiseTest, EachComponentDrawsFromItsOwnStream)
{
  DetectionNoiseConfig jitter_only = quietNoise();
  jitter_only.box_jitter = true;
  DetectionNoiseConfig with_confusion = jitter_only;
  with_confusion.confusion = true;
  with_confusion.van_to_car = 0.5;
  const std::vector<NoiseLabel> labels{noiseLabel("van", kCarBox, 0, 0.F, 0),
                                       noiseLabel("car", kCarBox, 0, 0.F, 1)};
  for (std::int64_t frame = 0; frame < 50; ++frame)
  {
    const auto a = applyDetectionNoise(jitter_only, frame, labels, 1242, 375);
    const auto b = applyDetectionNoise(with_confusion, frame, labels, 1242, 375);
    ASSERT_EQ(a.size(), 2U);
    ASSERT_EQ(b.size(), 2U);
    for (std::size_t i = 0; i < 2; ++i)
    {
      EXPECT_EQ(a[i].box.x_min, b[i].box.x_min);
      EXPECT_EQ(a[i].box.y_max, b[i].box.y_max);
    }
  }
}

TEST(DetectionNoiseTest, EdgeErrorsHaveTheirBiasAndSpread)
{
  DetectionNoiseConfig c = quietNoise();
  c.box_jitter = true;
  c.left = {0.02, 2.0, 0.04, 0.0, 1.0};
  c.top = {0.0, 1.0, 0.0, 0.0, 1.0};
  c.right = {-0.04, 0.0, 0.05, 0.0, 1.0};
  c.bottom = {-0.03, 1.0, 0.02, 0.3, 3.0};
  const double h = kCarBox.y_max - kCarBox.y_min;
  Moments left, top, right, bottom;
  for (int frame = 0; frame < kDraws; ++frame)
  {
    const auto d = applyDetectionNoise(c, frame, {noiseLabel("car", kCarBox)}, 1242, 375);
    ASSERT_EQ(d.size(), 1U);
    left.values.push_back(d[0].box.x_min - kCarBox.x_min);
    top.values.push_back(d[0].box.y_min - kCarBox.y_min);
    right.values.push_back(d[0].box.x_max - kCarBox.x_max);
    bottom.values.push_back(d[0].box.y_max - kCarBox.y_max);
  }
  const auto expect_edge = [&](const Moments& m, const BoxEdgeNoise& e, const char* name)
  {
    const double sigma = std::hypot(e.sigma_px, e.sigma_fraction * h);
    const double sd =
        sigma * std::sqrt(1.0 - e.tail_probability + e.tail_probability * e.tail_scale * e.tail_scale);
    EXPECT_NEAR(m.mean(), e.bias * h, 4.0 * sd / std::sqrt(kDraws)) << name;
    EXPECT_NEAR(m.sd(), sd, 0.03 * sd) << name;
  };
  expect_edge(left, c.left, "left");
  expect_edge(top, c.top, "top");
  expect_edge(right, c.right, "right");
  expect_edge(bottom, c.bottom, "bottom");
  // The tails: with 30 % of the deviations 3x wider, 3-sigma excursions are far more frequent
  // than a Gaussian's 0.27 %.
  const double core = std::hypot(c.bottom.sigma_px, c.bottom.sigma_fraction * h);
  const double outside = static_cast<double>(std::count_if(
                             bottom.values.begin(), bottom.values.end(),
                             [&](double v) { return std::abs(v - c.bottom.bias * h) > 3.0 * core; })) /
                         kDraws;
  const double expected = 0.3 * std::erfc(1.0 / std::sqrt(2.0)) + 0.7 * std::erfc(3.0 / std::sqrt(2.0));
  EXPECT_NEAR(outside, expected, 0.01);
  // A pedestrian's deviations are person_scale times a car's of the same height.
  c.person_scale = 0.5;
  Moments person_bottom;
  for (int frame = 0; frame < kDraws; ++frame)
  {
    const auto d = applyDetectionNoise(c, frame, {noiseLabel("pedestrian", kCarBox)}, 1242, 375);
    ASSERT_EQ(d.size(), 1U);
    person_bottom.values.push_back(d[0].box.y_max - kCarBox.y_max);
  }
  EXPECT_NEAR(person_bottom.mean(), c.bottom.bias * h, 0.05);
  EXPECT_NEAR(person_bottom.sd(), 0.5 * bottom.sd(), 0.03 * 0.5 * bottom.sd());
  // An edge on the image border stays there.
  const BoundingBox cut{0.F, 150.F, 200.F, 375.F};
  for (int frame = 0; frame < 20; ++frame)
  {
    const auto d = applyDetectionNoise(c, frame, {noiseLabel("car", cut)}, 1242, 375);
    ASSERT_EQ(d.size(), 1U);
    EXPECT_EQ(d[0].box.x_min, 0.F);
    EXPECT_EQ(d[0].box.y_max, 375.F);
  }
}

TEST(DetectionNoiseTest, PresenceAndScoresFollowTheModel)
{
  DetectionNoiseConfig c = quietNoise();
  c.misses = true;
  c.min_score = 1e-4;  // the score's normal hardly truncated
  const double h = kCarBox.y_max - kCarBox.y_min;
  for (const auto& [label, occluded, truncated] : {std::tuple<std::string, int, float>{"car", 0, 0.F},
                                                   std::tuple<std::string, int, float>{"pedestrian", 1, 0.F},
                                                   std::tuple<std::string, int, float>{"van", 2, 0.3F}})
  {
    SCOPED_TRACE(label);
    const std::size_t index =
        std::find(noiseModelLabels().begin(), noiseModelLabels().end(), label) - noiseModelLabels().begin();
    int present = 0;
    int above_half = 0;
    Moments logits;
    for (int frame = 0; frame < kDraws; ++frame)
    {
      const auto d =
          applyDetectionNoise(c, frame, {noiseLabel(label, kCarBox, occluded, truncated)}, 1242, 375);
      if (d.empty())
      {
        continue;
      }
      ++present;
      above_half += d[0].score >= 0.5F;
      const double s = d[0].score / c.score_max;
      logits.values.push_back(std::log(s / (1.0 - s)));
    }
    const double p = sigmoidOf(c.presence.predictor(index, h, occluded, truncated));
    EXPECT_NEAR(static_cast<double>(present) / kDraws, p, 4.0 * std::sqrt(p * (1 - p) / kDraws) + 1e-3);
    const double mean = c.score.predictor(index, h, occluded, truncated);
    EXPECT_NEAR(logits.mean(), mean, 0.03);
    EXPECT_NEAR(logits.sd(), c.score_sigma, 0.03);
    const double cut = std::log((0.5 / c.score_max) / (1.0 - 0.5 / c.score_max));
    const double q = 0.5 * std::erfc((cut - mean) / c.score_sigma / std::sqrt(2.0));
    EXPECT_NEAR(static_cast<double>(above_half) / present, q, 0.015);
  }
  // The default floor: no score below min_score.
  DetectionNoiseConfig floor = quietNoise();
  floor.misses = true;
  for (int frame = 0; frame < 2000; ++frame)
  {
    for (const Detection& d :
         applyDetectionNoise(floor, frame, {noiseLabel("cyclist", {600, 180, 612, 200}, 2)}, 1242, 375))
    {
      EXPECT_GE(d.score, floor.min_score);
      EXPECT_LE(d.score, floor.score_max);
    }
  }
}

TEST(DetectionNoiseTest, ScoresFarBelowTheFloorStayAtTheFloor)
{
  // The score's normal truncated at a = (floor - mean) / sigma far in its tail: P(Z >= a) down to
  // subnormal (a = 37.9) and to 0 (a = 45); every score finite, at or just above min_score.
  DetectionNoiseConfig c = quietNoise();
  c.misses = true;
  c.score_sigma = 1.0;
  const double h = kCarBox.y_max - kCarBox.y_min;
  const double floor = std::log((c.min_score / c.score_max) / (1.0 - c.min_score / c.score_max));
  for (const double a : {3.0, 10.0, 20.0, 37.9, 45.0})
  {
    SCOPED_TRACE(a);
    c.score.car = 0.0;
    c.score.car = floor - a - c.score.predictor(0, h, 0, 0.0);
    int found = 0;
    for (int frame = 0; frame < 500; ++frame)
    {
      for (const Detection& d : applyDetectionNoise(c, frame, {noiseLabel("car", kCarBox)}, 1242, 375))
      {
        ++found;
        ASSERT_TRUE(std::isfinite(d.score));
        EXPECT_GE(d.score, c.min_score);
        // Z - a of a normal truncated at a > 0 is about exponential with mean 1 / a: below 20 / a.
        EXPECT_LE(d.score, c.score_max * sigmoidOf(floor + 20.0 / a));
      }
    }
    EXPECT_GT(found, 400);
  }
}

TEST(NormalQuantileTest, BoostMathsQuantileOverTheWholeInterval)
{
  EXPECT_EQ(normalQuantile(0.5), 0.0);
  EXPECT_NEAR(normalQuantile(0.975), 1.959963984540054, 1e-15);
  EXPECT_NEAR(normalQuantile(0.025), -1.959963984540054, 1e-15);
  EXPECT_NEAR(normalQuantile(0.8413447460685429), 1.0, 1e-14);  // Phi(1)
  EXPECT_NEAR(normalQuantile(1e-10), -6.361340902404056, 1e-13);
  // Phi(x(p)) = p, relative, deep into both tails.
  for (const double p : {1e-300, 1e-100, 1e-20, 1e-5, 0.1, 0.3, 0.7, 0.9, 0.999})
  {
    const double x = normalQuantile(p);
    EXPECT_NEAR(0.5 * std::erfc(-x / std::sqrt(2.0)) / p, 1.0, 1e-12) << p;
  }
  EXPECT_NEAR(normalQuantile(std::numeric_limits<double>::denorm_min()), -38.4674, 1e-4);
  EXPECT_NEAR(normalQuantile(1.0 - 1e-16), 8.2095, 1e-4);
  // Outside (0, 1): a domain error that names p (0 and 1, whose quantiles are infinite, too).
  for (const double p : {0.0, 1.0, -0.5, 1.5, std::numeric_limits<double>::quiet_NaN(),
                         std::numeric_limits<double>::infinity(), -std::numeric_limits<double>::infinity()})
  {
    EXPECT_THROW(normalQuantile(p), std::domain_error) << p;
  }
  try
  {
    normalQuantile(1.0);
    FAIL() << "no exception";
  }
  catch (const std::domain_error& e)
  {
    EXPECT_NE(std::string(e.what()).find("not in (0, 1)"), std::string::npos) << e.what();
  }
}

TEST(DetectionNoiseTest, HiddenAndUnknownLabels)
{
  DetectionNoiseConfig c = quietNoise();
  c.misses = true;
  c.presence.car = 50.0;  // always present
  const std::vector<NoiseLabel> labels{noiseLabel("car", kCarBox, 3, 0.F, 0),
                                       noiseLabel("tram", kCarBox, 0, 0.F, 1)};
  EXPECT_TRUE(applyDetectionNoise(c, 0, labels, 1242, 375).empty());
  c.fully_occluded_detected = true;
  c.keep_other_labels = true;
  const auto d = applyDetectionNoise(c, 0, labels, 1242, 375);
  ASSERT_EQ(d.size(), 2U);
  EXPECT_EQ(d[0].label, "tram");  // its file score 1 ranks first
  EXPECT_EQ(d[1].label, "car");
}

TEST(DetectionNoiseTest, ConfusionPartialBoxesAndExtraBoxes)
{
  DetectionNoiseConfig c = quietNoise();
  c.confusion = true;
  std::map<std::string, int> counts;
  for (int frame = 0; frame < kDraws; ++frame)
  {
    const auto d = applyDetectionNoise(c, frame, {noiseLabel("van", kCarBox)}, 1242, 375);
    ASSERT_EQ(d.size(), 1U);
    ++counts[d[0].label];
    EXPECT_EQ(d[0].class_id, noiseClassId(d[0].label));
  }
  const auto share = [&](const std::string& l) { return static_cast<double>(counts[l]) / kDraws; };
  EXPECT_NEAR(share("car"), c.van_to_car, 0.015);
  EXPECT_NEAR(share("truck"), c.van_to_truck, 0.015);
  EXPECT_NEAR(share("van"), 1.0 - c.van_to_car - c.van_to_truck, 0.015);
  EXPECT_EQ(noiseClassId("cyclist"), 5U);

  DetectionNoiseConfig p = quietNoise();
  p.partial_boxes = true;
  const double w = kCarBox.x_max - kCarBox.x_min;
  for (int occluded = 0; occluded <= 2; ++occluded)
  {
    int partial = 0;
    Moments fraction;
    for (int frame = 0; frame < kDraws; ++frame)
    {
      const auto d = applyDetectionNoise(p, frame, {noiseLabel("car", kCarBox, occluded)}, 1242, 375);
      ASSERT_EQ(d.size(), 1U);
      const double kept = (d[0].box.x_max - d[0].box.x_min) / w;
      if (kept < 1.0 - 1e-6)
      {
        ++partial;
        fraction.values.push_back(kept);
        EXPECT_TRUE(d[0].box.x_min == kCarBox.x_min || d[0].box.x_max == kCarBox.x_max) << "on one side";
        EXPECT_GE(kept, p.partial_width_min - 1e-5);
        EXPECT_LE(kept, p.partial_width_max + 1e-5);
      }
    }
    const double expected = std::array<double, 3>{p.partial_occlusion0, p.partial_occlusion1,
                                                  p.partial_occlusion2}[static_cast<std::size_t>(occluded)];
    EXPECT_NEAR(static_cast<double>(partial) / kDraws, expected, 0.01) << "occlusion " << occluded;
    EXPECT_NEAR(fraction.mean(), (p.partial_width_min + p.partial_width_max) / 2.0, 0.01);
  }

  DetectionNoiseConfig e = quietNoise();
  e.extra_boxes = true;
  e.extra_rate = 0.8;
  long extra = 0;
  long extra_above = 0;
  for (int frame = 0; frame < kDraws; ++frame)
  {
    const auto d = applyDetectionNoise(e, frame, {noiseLabel("car", kCarBox)}, 1242, 375);
    ASSERT_GE(d.size(), 1U);
    extra += static_cast<long>(d.size()) - 1;
    extra_above += std::count_if(d.begin(), d.end(),
                                 [](const Detection& x) { return x.score >= 0.5F && x.score < 1.F; });
  }
  EXPECT_NEAR(static_cast<double>(extra) / kDraws, e.extra_rate, 0.03);
  const auto tail = [&](double s)
  {
    const double z = std::log((s / e.score_max) / (1.0 - s / e.score_max));
    return 0.5 * std::erfc((z - e.background.score_mean) / e.background.score_sigma / std::sqrt(2.0));
  };
  EXPECT_NEAR(static_cast<double>(extra_above) / extra, tail(0.5) / tail(e.min_score), 0.006);
}

TEST(DetectionNoiseTest, FalsePositivesFollowTheirModel)
{
  DetectionNoiseConfig c = quietNoise();
  c.false_positives = true;
  FalsePositiveNoise& f = c.background;
  long count = 0;
  long above = 0;
  std::map<std::string, long> labels;
  std::vector<double> log_heights;
  for (int frame = 0; frame < kDraws; ++frame)
  {
    for (const Detection& d : applyDetectionNoise(c, frame, {}, 1242, 375))
    {
      ++count;
      above += d.score >= 0.5F;
      ++labels[d.label];
      EXPECT_GE(d.box.y_max, f.bottom_min * 375 - 1e-3);
      EXPECT_LE(d.box.y_max, f.bottom_max * 375 + 1e-3);
      EXPECT_GE(d.box.x_min, 0.F);
      EXPECT_LE(d.box.x_max, 1242.F);
      if (d.box.y_min > 0.F)
      {
        log_heights.push_back(std::log(d.box.y_max - d.box.y_min));
      }
    }
  }
  EXPECT_NEAR(static_cast<double>(count) / kDraws, f.rate, 0.05);
  const double sum = f.car + f.van + f.truck + f.pedestrian + f.cyclist;
  EXPECT_NEAR(static_cast<double>(labels["car"]) / count, f.car / sum, 0.01);
  EXPECT_NEAR(static_cast<double>(labels["pedestrian"]) / count, f.pedestrian / sum, 0.01);
  std::nth_element(log_heights.begin(), log_heights.begin() + log_heights.size() / 2, log_heights.end());
  EXPECT_NEAR(std::exp(log_heights[log_heights.size() / 2]), f.height_median, 0.03 * f.height_median);
  const auto tail = [&](double s)
  {
    const double z = std::log((s / c.score_max) / (1.0 - s / c.score_max));
    return 0.5 * std::erfc((z - f.score_mean) / f.score_sigma / std::sqrt(2.0));
  };
  EXPECT_NEAR(static_cast<double>(above) / count, tail(0.5) / tail(c.min_score), 0.005);
  // No image size: no false positive.
  EXPECT_TRUE(applyDetectionNoise(c, 0, {}, 0, 0).empty());
}

TEST(DetectionNoiseTest, TheReplayThresholdsTheNoisyScores)
{
  DetectionReplayConfig config = groundTruthConfig();
  config.noise.enabled = true;
  config.noise.seed = 3;
  config.score_threshold = 0.5;
  DetectionReplay replay(config);
  int published = 0;
  for (int repeat = 0; repeat < 200; ++repeat)
  {
    config.noise.seed = static_cast<std::uint32_t>(repeat);
    const auto d = DetectionReplay(config).detectionsOf(0, 1242, 375);
    for (std::size_t i = 0; i < d.size(); ++i)
    {
      ++published;
      EXPECT_GE(d[i].score, 0.5F);
      EXPECT_LT(d[i].score, 1.F);
      if (i > 0)
      {
        EXPECT_GE(d[i - 1].score, d[i].score) << "in order of decreasing score";
      }
    }
  }
  EXPECT_GT(published, 0);
}

TEST(DetectionNoiseTest, ValidationNamesTheKey)
{
  EXPECT_NO_THROW(DetectionNoiseConfig{}.validate());
  const auto message = [](const std::function<void(DetectionNoiseConfig&)>& change)
  {
    DetectionReplayConfig config = groundTruthConfig();
    change(config.noise);
    try
    {
      config.validate();
    }
    catch (const std::invalid_argument& e)
    {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_NE(message([](DetectionNoiseConfig& c) { c.bottom.sigma_px = -1.0; })
                .find("replay/noise/box/bottom/sigma_px"),
            std::string::npos);
  EXPECT_NE(message([](DetectionNoiseConfig& c) { c.left.tail_probability = 1.5; })
                .find("replay/noise/box/left/tail_probability"),
            std::string::npos);
  EXPECT_NE(message([](DetectionNoiseConfig& c) { c.van_to_truck = 0.5; })
                .find("replay/noise/confusion/van_to_truck"),
            std::string::npos);
  EXPECT_NE(message([](DetectionNoiseConfig& c) { c.min_score = 0.97; }).find("replay/noise/min_score"),
            std::string::npos);
  EXPECT_NE(message([](DetectionNoiseConfig& c) { c.score_sigma = 0.0; }).find("replay/noise/score/sigma"),
            std::string::npos);
  EXPECT_NE(
      message([](DetectionNoiseConfig& c) { c.person_scale = -0.1; }).find("replay/noise/box/person_scale"),
      std::string::npos);
  EXPECT_NE(message([](DetectionNoiseConfig& c) { c.presence.van = NAN; }).find("replay/noise/presence/van"),
            std::string::npos);
  EXPECT_NE(message([](DetectionNoiseConfig& c) { c.partial_width_max = 0.2; })
                .find("replay/noise/partial/width_max"),
            std::string::npos);
  EXPECT_NE(message([](DetectionNoiseConfig& c) { c.extra_rate = -1.0; }).find("replay/noise/extra_rate"),
            std::string::npos);
  EXPECT_NE(message([](DetectionNoiseConfig& c) { c.background.bottom_max = 1.5; })
                .find("replay/noise/false_positives/bottom_max"),
            std::string::npos);
  EXPECT_NE(message(
                [](DetectionNoiseConfig& c)
                {
                  c.background.car = c.background.van = c.background.truck = 0.0;
                  c.background.pedestrian = c.background.cyclist = 0.0;
                })
                .find("replay/noise/false_positives/car"),
            std::string::npos);
}

}  // namespace
}  // namespace grid_vision_fusion
