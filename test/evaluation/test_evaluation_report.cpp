// Tests of the evaluation outputs: JSON, Markdown tables, Cartucho folders and plots.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "grid_vision_fusion/evaluation/evaluation_report.h"

namespace grid_vision_fusion
{
namespace
{
namespace fs = std::filesystem;

EvalObject object(const std::string& frame, const std::string& label, Motion motion, BoundingBox box,
                  float score, double longitudinal_m = 10.0)
{
  EvalObject o;
  o.frame = frame;
  o.label = label;
  o.motion = motion;
  o.box = box;
  o.score = score;
  o.longitudinal_m = longitudinal_m;
  return o;
}

std::string readFile(const fs::path& path)
{
  std::ifstream file(path);
  std::stringstream content;
  content << file.rdbuf();
  return content.str();
}

const BoundingBox kA{10.F, 20.F, 109.F, 119.F};

struct Case
{
  std::vector<EvalObject> gt{object("000000", "car", Motion::kDynamic, kA, 1.F),
                             object("000001", "car", Motion::kStatic, kA, 1.F),
                             object("000002", "van", Motion::kStatic, kA, 1.F, 45.0)};  // beyond 30 m
  std::vector<EvalObject> det{object("000000", "car", Motion::kDynamic, kA, 0.875F),
                              object("000001", "car", Motion::kDynamic, kA, 0.5F)};
  EvaluationConfig config;
  EvaluationResult result = evaluate(gt, det, config);
};
}  // namespace

TEST(EvaluationReport, JsonCarriesTheFigures)
{
  const Case c;
  const std::string text = metricsJson(c.result, c.config);
  const nlohmann::json json = nlohmann::json::parse(text);
  EXPECT_EQ(json["mAP"], 0.5) << text;  // dynamicCar 1, staticCar 0
  const nlohmann::json& dynamic_car = json["classes"][0];
  EXPECT_EQ(dynamic_car["name"], "dynamicCar");
  EXPECT_EQ(dynamic_car["ground_truth"], 1);
  EXPECT_EQ(dynamic_car["detections"], 2);
  EXPECT_EQ(dynamic_car["true_positives"], 1);
  EXPECT_EQ(dynamic_car["false_positives"], 1);
  EXPECT_EQ(dynamic_car["precision"], 0.5);
  EXPECT_EQ(dynamic_car["recall"], 1.0);
  const nlohmann::json counts = {{0, 0, 0}, {0, 0, 1}, {0, 0, 1}};
  EXPECT_EQ(json["motion_confusion"]["counts"], counts) << text;
  // Per class: the confusion and the counts per truth speed band (no state here: moving ones
  // fall in the band "unknown").
  const nlohmann::json by_class = {
      {"car",
       {{"confusion", counts}, {"by_truth_speed_band", {{"static", {0, 0, 1}}, {"unknown", {0, 0, 1}}}}}}};
  EXPECT_EQ(json["motion_by_class"], by_class) << text;
}

TEST(EvaluationReport, JsonKeepsItsKeysInOrderAndItsFiguresToSixDecimals)
{
  const Case c;
  const std::string text = metricsJson(c.result, c.config);
  std::vector<std::string> keys;
  const nlohmann::ordered_json json = nlohmann::ordered_json::parse(text);
  for (const auto& entry : json.items())
  {
    keys.push_back(entry.key());
  }
  const std::vector<std::string> expected{"config",
                                          "mAP",
                                          "classes",
                                          "motion_confusion",
                                          "motion_by_class",
                                          "position_error_m",
                                          "speed_error_mps",
                                          "heading_error_rad",
                                          "p_dynamic_calibration"};
  EXPECT_EQ(keys, expected);
  EvaluationResult result = c.result;
  result.mean_average_precision = 2.0 / 3.0;
  EXPECT_EQ(nlohmann::json::parse(metricsJson(result, c.config))["mAP"], 0.666667);
  result.position_error_m.median = std::nan("");
  EXPECT_TRUE(nlohmann::json::parse(metricsJson(result, c.config))["position_error_m"]["median"].is_null());
}

TEST(EvaluationReport, MatchesCsv)
{
  EvalObject gt = object("000003", "cyclist", Motion::kDynamic, kA, 1.F, 12.5);
  gt.has_state = true;
  gt.vx = 4.0;
  gt.track_id = 7;
  EvalObject det = gt;
  det.track_id = -1;  // a label file's detection: no identity, an empty field
  det.motion = Motion::kStatic;
  det.x = 1.0;
  det.vx = 0.0;
  EvalObject tracked = det;  // a DetectedObject's: its P(dynamic) in the last field
  tracked.frame = "000004";
  tracked.p_dynamic = 0.25;
  EvalObject tracked_gt = gt;
  tracked_gt.frame = "000004";
  const EvaluationResult result = evaluate({gt, tracked_gt}, {det, tracked}, EvaluationConfig{});
  EXPECT_EQ(matchesCsv(result),
            "frame,label,truth_motion,predicted_motion,truth_band,truth_speed_mps,longitudinal_m,"
            "position_error_m,speed_error_mps,heading_error_rad,truth_id,track_id,p_dynamic\n"
            "000003,cyclist,dynamic,static,>3,4.000,12.50,1.000,4.000,,7,,\n"
            "000004,cyclist,dynamic,static,>3,4.000,12.50,1.000,4.000,,7,,0.2500\n");
  EXPECT_EQ(matchesCsv(EvaluationResult{}).find('\n') + 1,
            matchesCsv(EvaluationResult{}).size());  // header only
}

TEST(ProbabilityCalibration, BinsBrierScoreAndCalibrationError)
{
  auto match = [](Motion truth, double p)
  {
    MatchedObject m;
    m.truth_motion = truth;
    m.p_dynamic = p;
    return m;
  };
  const std::vector<MatchedObject> matches = {
      match(Motion::kStatic, 0.05),         match(Motion::kStatic, 0.15),
      match(Motion::kDynamic, 0.15),        match(Motion::kDynamic, 1.0),
      match(Motion::kDynamic, 0.95),        match(Motion::kUnknown, 0.5),  // truth unknown: left out
      match(Motion::kDynamic, -1.0),  // no P(dynamic) (a label file): left out
      match(Motion::kStatic, std::nan("")), match(Motion::kStatic, 1.5)};
  const ProbabilityCalibration c = probabilityCalibration(matches);
  EXPECT_EQ(c.total, 5U);
  EXPECT_EQ(c.count[0], 1U);
  EXPECT_EQ(c.dynamic[0], 0U);
  EXPECT_EQ(c.count[1], 2U);
  EXPECT_EQ(c.dynamic[1], 1U);
  EXPECT_EQ(c.count[9], 2U);  // 1.0 falls in the last bin
  EXPECT_EQ(c.dynamic[9], 2U);
  EXPECT_EQ(c.count[5], 0U);
  EXPECT_NEAR(c.mean_p[1], 0.15, 1e-12);
  EXPECT_NEAR(c.mean_p[9], 0.975, 1e-12);
  EXPECT_NEAR(c.brier, (0.05 * 0.05 + 0.15 * 0.15 + 0.85 * 0.85 + 0.05 * 0.05) / 5.0, 1e-12);
  EXPECT_NEAR(c.expected_calibration_error, 0.2 * 0.05 + 0.4 * 0.35 + 0.4 * 0.025, 1e-12);

  const ProbabilityCalibration none = probabilityCalibration({match(Motion::kDynamic, -1.0)});
  EXPECT_EQ(none.total, 0U);
  EXPECT_EQ(none.brier, 0.0);
}

TEST(EvaluationReport, CalibrationInTheReportWhenTheDetectionsHaveAProbability)
{
  EvalObject gt = object("000001", "car", Motion::kDynamic, kA, 1.F);
  EvalObject det = gt;
  det.p_dynamic = 0.82;
  EvaluationResult result = evaluate({gt}, {det}, EvaluationConfig{});
  EXPECT_EQ(result.p_dynamic_calibration.total, 1U);
  EXPECT_EQ(result.p_dynamic_calibration.count[8], 1U);
  const std::string md = reportMarkdown(result, EvaluationConfig{});
  EXPECT_NE(md.find("## P(dynamic) calibration"), std::string::npos) << md;
  EXPECT_NE(md.find("| 0.8-0.9 | 1 | 0.820 | 100.0 |"), std::string::npos) << md;
  const nlohmann::json calibration =
      nlohmann::json::parse(metricsJson(result, EvaluationConfig{}))["p_dynamic_calibration"];
  EXPECT_EQ(calibration["matches"], 1);
  EXPECT_EQ(calibration["brier"], 0.0324);
  const nlohmann::json bin = {{"low", 0.8}, {"high", 0.9}, {"count", 1}, {"dynamic", 1}, {"mean_p", 0.82}};
  EXPECT_EQ(calibration["bins"][8], bin);

  det.p_dynamic = -1.0;  // a label file: no probability, no section
  result = evaluate({gt}, {det}, EvaluationConfig{});
  EXPECT_EQ(reportMarkdown(result, EvaluationConfig{}).find("calibration"), std::string::npos);
}

TEST(EvaluationReport, MarkdownTables)
{
  const Case c;
  const std::string md = reportMarkdown(c.result, c.config);
  EXPECT_NE(md.find("| dynamicCar | 50.0 | 100.0 | 66.7 | 1 | 1 | 1 |"), std::string::npos) << md;
  EXPECT_NE(md.find("| staticCar | 0.0 | 0.0 | 0.0 | 1 | 0 | 0 |"), std::string::npos) << md;
  EXPECT_NE(md.find("| **mAP** | **50.0** |"), std::string::npos) << md;
  EXPECT_NE(md.find("| static | 0 | 0 | 1 |"), std::string::npos) << md;
}

TEST(EvaluationReport, CartuchoFolders)
{
  const Case c;
  const fs::path dir = fs::path(testing::TempDir()) / "cartucho";
  fs::remove_all(dir);
  writeCartuchoFolders(dir.string(), c.gt, c.det, c.config);
  EXPECT_EQ(readFile(dir / "ground-truth" / "000000.txt"), "dynamicCar 10.00 20.00 109.00 119.00\n");
  EXPECT_EQ(readFile(dir / "detection-results" / "000000.txt"),
            "dynamicCar 0.875000 10.00 20.00 109.00 119.00\n");
  // The van beyond the range limit is written as difficult (ignored, as evaluate() does), in the
  // class of each motion; its frame has a (empty) detection file too.
  ASSERT_TRUE(fs::exists(dir / "ground-truth" / "000002.txt"));
  EXPECT_EQ(readFile(dir / "ground-truth" / "000002.txt"),
            "staticVan 10.00 20.00 109.00 119.00 difficult\nunknownVan 10.00 20.00 109.00 119.00 difficult\n"
            "dynamicVan 10.00 20.00 109.00 119.00 difficult\n");
  EXPECT_TRUE(fs::exists(dir / "detection-results" / "000002.txt"));
}

namespace
{
/// What Cartucho/mAP's main.py computes from the two folders (a transcription of its matching
/// and AP, github.com/Cartucho/mAP): per class its AP, the mAP over the classes with
/// non-difficult ground truth, and whether a precision divided zero by zero (main.py then stops
/// with ZeroDivisionError: the first detection of a class was ignored).
struct CartuchoResult
{
  std::map<std::string, double> ap;
  double map = 0.0;
  bool zero_division = false;
};

struct CartuchoBox
{
  std::string label;
  std::array<double, 4> box{};
  bool difficult = false;
  bool used = false;
  double confidence = 0.0;
  std::string file;
};

std::vector<std::string> fileIds(const fs::path& dir)
{
  std::vector<std::string> ids;
  for (const auto& entry : fs::directory_iterator(dir))
  {
    ids.push_back(entry.path().stem().string());
  }
  std::sort(ids.begin(), ids.end());
  return ids;
}

CartuchoResult cartucho(const fs::path& dir, double min_overlap)
{
  std::map<std::string, std::vector<CartuchoBox>> truth;  // file id -> ground truth
  std::map<std::string, std::size_t> counter;             // class -> non-difficult ground truth
  for (const std::string& id : fileIds(dir / "ground-truth"))
  {
    std::istringstream lines(readFile(dir / "ground-truth" / (id + ".txt")));
    for (std::string line; std::getline(lines, line);)
    {
      std::istringstream fields(line);
      CartuchoBox b;
      std::string flag;
      fields >> b.label >> b.box[0] >> b.box[1] >> b.box[2] >> b.box[3] >> flag;
      b.difficult = flag == "difficult";
      counter[b.label] += b.difficult ? 0 : 1;
      truth[id].push_back(b);
    }
  }
  CartuchoResult result;
  for (const auto& [label, count] : counter)
  {
    std::vector<CartuchoBox> dets;
    for (const std::string& id : fileIds(dir / "detection-results"))
    {
      std::istringstream lines(readFile(dir / "detection-results" / (id + ".txt")));
      for (std::string line; std::getline(lines, line);)
      {
        std::istringstream fields(line);
        CartuchoBox d;
        fields >> d.label >> d.confidence >> d.box[0] >> d.box[1] >> d.box[2] >> d.box[3];
        d.file = id;
        if (d.label == label)
        {
          dets.push_back(d);
        }
      }
    }
    std::stable_sort(dets.begin(), dets.end(),
                     [](const CartuchoBox& a, const CartuchoBox& b) { return a.confidence > b.confidence; });
    std::vector<double> tp(dets.size(), 0.0), fp(dets.size(), 0.0);
    for (std::size_t i = 0; i < dets.size(); ++i)
    {
      const auto& bb = dets[i].box;
      double ovmax = -1.0;
      CartuchoBox* match = nullptr;
      for (CartuchoBox& g : truth[dets[i].file])
      {
        if (g.label != label)
        {
          continue;
        }
        const double iw = std::min(bb[2], g.box[2]) - std::max(bb[0], g.box[0]) + 1.0;
        const double ih = std::min(bb[3], g.box[3]) - std::max(bb[1], g.box[1]) + 1.0;
        if (iw > 0.0 && ih > 0.0)
        {
          const double ua = (bb[2] - bb[0] + 1.0) * (bb[3] - bb[1] + 1.0) +
                            (g.box[2] - g.box[0] + 1.0) * (g.box[3] - g.box[1] + 1.0) - iw * ih;
          if (iw * ih / ua > ovmax)
          {
            ovmax = iw * ih / ua;
            match = &g;
          }
        }
      }
      if (ovmax >= min_overlap)
      {
        if (!match->difficult)
        {
          (match->used ? fp : tp)[i] = 1.0;
          match->used = true;
        }
      }
      else
      {
        fp[i] = 1.0;
      }
    }
    std::vector<double> rec{0.0}, prec{0.0};
    for (std::size_t i = 0; i < dets.size(); ++i)
    {
      tp[i] += i > 0 ? tp[i - 1] : 0.0;
      fp[i] += i > 0 ? fp[i - 1] : 0.0;
      result.zero_division = result.zero_division || tp[i] + fp[i] == 0.0;
      rec.push_back(tp[i] / static_cast<double>(count));
      prec.push_back(tp[i] + fp[i] > 0.0 ? tp[i] / (tp[i] + fp[i]) : 0.0);
    }
    rec.push_back(1.0);
    prec.push_back(0.0);
    for (std::size_t i = prec.size() - 1; i-- > 0;)
    {
      prec[i] = std::max(prec[i], prec[i + 1]);
    }
    double ap = 0.0;
    for (std::size_t i = 1; i < rec.size(); ++i)
    {
      ap += rec[i] != rec[i - 1] ? (rec[i] - rec[i - 1]) * prec[i] : 0.0;
    }
    if (count > 0)
    {
      result.ap[label] = ap;
      result.map += ap;
    }
  }
  std::size_t classes = 0;
  for (const auto& entry : counter)
  {
    classes += entry.second > 0 ? 1 : 0;
  }
  result.map = classes ? result.map / static_cast<double>(classes) : 0.0;
  return result;
}
}  // namespace

TEST(EvaluationReport, CartuchoExportGivesTheSameApAndMap)
{
  // Frame 0: static cars A (10 m), B (difficult), C (31 m, beyond the limit), a DontCare region
  // D, a dynamic van E. Frame 1: a static car A1, a dynamic car F. Frame 2: a static car A2.
  const BoundingBox a{100.F, 100.F, 199.F, 199.F}, b{300.F, 100.F, 399.F, 199.F},
      c{500.F, 100.F, 599.F, 199.F};
  const BoundingBox d{700.F, 100.F, 799.F, 199.F}, e{900.F, 100.F, 999.F, 199.F},
      nowhere{0.F, 300.F, 49.F, 349.F};
  std::vector<EvalObject> gt{
      object("0", "car", Motion::kStatic, a, 1.F),        object("0", "car", Motion::kStatic, b, 1.F),
      object("0", "car", Motion::kStatic, c, 1.F, 31.0),  object("0", "dontcare", Motion::kUnknown, d, 1.F),
      object("0", "van", Motion::kDynamic, e, 1.F, 15.0), object("1", "car", Motion::kStatic, a, 1.F, 20.0),
      object("1", "car", Motion::kDynamic, b, 1.F, 25.0), object("2", "car", Motion::kStatic, a, 1.F, 29.0)};
  gt[1].difficult = true;
  gt[3].dont_care = true;
  const std::vector<EvalObject> det{
      object("0", "car", Motion::kStatic, c, 0.95F, 29.0),  // on C (beyond): ignored, first of its class
      object("0", "car", Motion::kStatic, a, 0.9F),         // TP
      object("0", "car", Motion::kStatic, b, 0.85F),        // on the difficult B: ignored
      object("0", "car", Motion::kStatic, d, 0.8F),         // in the DontCare region: ignored
      object("0", "car", Motion::kStatic, a, 0.75F),        // duplicate: FP
      object("1", "car", Motion::kStatic, a, 0.7F, 31.0),   // TP although beyond the limit
      object("1", "car", Motion::kStatic, nowhere, 0.65F, 33.0),  // beyond, matching nothing: left out
      object("1", "car", Motion::kDynamic, b, 0.6F),              // TP
      object("1", "car", Motion::kStatic, b, 0.55F),              // wrong motion: FP
      object("0", "van", Motion::kDynamic, e, 0.5F),              // TP
      object("2", "car", Motion::kStatic, nowhere, 0.45F),        // FP
      object("2", "truck", Motion::kDynamic, nowhere, 0.4F),      // a class without ground truth
      object("0", "car", Motion::kDynamic, c, 0.35F),             // C (beyond), wrong motion: ignored
      object("0", "car", Motion::kDynamic, b, 0.3F)};             // B (difficult), wrong motion: FP
  const EvaluationConfig config;
  const EvaluationResult result = evaluate(gt, det, config);
  const fs::path dir = fs::path(testing::TempDir()) / "cartucho_map";
  fs::remove_all(dir);
  writeCartuchoFolders(dir.string(), gt, det, config);
  EXPECT_EQ(fileIds(dir / "ground-truth"), fileIds(dir / "detection-results"));
  // The difficult B in its class, C (beyond the limit) in the class of each motion, for the
  // detections of it that report another motion; no DontCare region.
  EXPECT_EQ(
      readFile(dir / "ground-truth" / "0.txt"),
      "staticCar 100.00 100.00 199.00 199.00\nstaticCar 300.00 100.00 399.00 199.00 difficult\n"
      "staticCar 500.00 100.00 599.00 199.00 difficult\nunknownCar 500.00 100.00 599.00 199.00 difficult\n"
      "dynamicCar 500.00 100.00 599.00 199.00 difficult\n"
      "dynamicVan 900.00 100.00 999.00 199.00\n");
  // The true and false positives only.
  EXPECT_EQ(
      readFile(dir / "detection-results" / "0.txt"),
      "staticCar 0.900000 100.00 100.00 199.00 199.00\nstaticCar 0.750000 100.00 100.00 199.00 199.00\n"
      "dynamicVan 0.500000 900.00 100.00 999.00 199.00\ndynamicCar 0.300000 300.00 100.00 399.00 199.00\n");

  const CartuchoResult cartucho_result = cartucho(dir, config.iou_threshold);
  EXPECT_FALSE(cartucho_result.zero_division);
  // staticCar: 3 counted truths; counted detections TP, FP, TP, FP, FP: AP = 1/3 · 1 + 1/3 · 2/3.
  ASSERT_EQ(cartucho_result.ap.size(), 3U);
  for (const ClassMetrics& m : result.classes)
  {
    if (m.ground_truth > 0)
    {
      ASSERT_EQ(cartucho_result.ap.count(m.name), 1U) << m.name;
      EXPECT_NEAR(cartucho_result.ap.at(m.name), m.average_precision, 1e-12) << m.name;
    }
  }
  EXPECT_NEAR(cartucho_result.ap.at("staticCar"), 1.0 / 3.0 + 2.0 / 9.0, 1e-12);
  EXPECT_NEAR(cartucho_result.map, result.mean_average_precision, 1e-12);
  // dynamicCar: F found (0.6) before the false B (0.3): AP 1.
  EXPECT_NEAR(result.mean_average_precision, (5.0 / 9.0 + 1.0 + 1.0) / 3.0, 1e-12);
}

TEST(EvaluationReport, PrCurveIsDrawn)
{
  ClassMetrics m;
  m.name = "dynamicCar";
  m.average_precision = 1.0;
  m.recall_curve = {0.5, 1.0};
  m.precision_curve = {1.0, 1.0};
  const cv::Mat plot = drawPrCurve(m);
  ASSERT_EQ(plot.size(), cv::Size(640, 480));
  // Precision 1 across the whole recall range: the curve runs along the top of the plot area
  // (y = 50) from x = 70 to 610.
  const cv::Vec3b at_mid = plot.at<cv::Vec3b>(50, 340);
  EXPECT_EQ(at_mid, cv::Vec3b(200, 80, 0));
}

TEST(EvaluationReport, HistogramBars)
{
  // Values 0.1 ×3 and 1.0 ×1 with 10 bins up to 1.0: bin 1 holds 3, bin 9 holds 1.
  const ErrorStats stats = errorStats({0.1, 0.1, 0.1, 1.0});
  const cv::Mat plot = drawHistogram(stats, "position error", "m", 10);
  // y axis up to ceil(3·1.1) = 4. Bar of bin 1 spans x ∈ [124, 178), 3/4 of 360 px above y = 410.
  EXPECT_EQ(plot.at<cv::Vec3b>(300, 150), cv::Vec3b(200, 80, 0));
  EXPECT_NE(plot.at<cv::Vec3b>(125, 150), cv::Vec3b(200, 80, 0));
  // Bin 9 reaches 1/4·360 = 90 px: filled at y = 380, empty at y = 250.
  EXPECT_EQ(plot.at<cv::Vec3b>(380, 590), cv::Vec3b(200, 80, 0));
  EXPECT_NE(plot.at<cv::Vec3b>(250, 590), cv::Vec3b(200, 80, 0));
  // Empty bin 5: nothing drawn above the axis.
  EXPECT_NE(plot.at<cv::Vec3b>(400, 350), cv::Vec3b(200, 80, 0));
  EXPECT_THROW(drawHistogram(stats, "x", "m", 0), std::invalid_argument);
}

TEST(EvaluationReport, WritesAllOutputs)
{
  const Case c;
  const fs::path dir = fs::path(testing::TempDir()) / "evaluation_out";
  fs::remove_all(dir);
  writeEvaluationOutputs(dir.string(), c.result, c.config, c.gt, c.det);
  for (const char* name : {"metrics.json", "report.md", "matches.csv", "pr_dynamicCar.png",
                           "pr_staticCar.png", "hist_position.png", "hist_speed.png", "hist_heading.png"})
  {
    EXPECT_TRUE(fs::exists(dir / name)) << name;
  }
  EXPECT_EQ(cv::imread((dir / "pr_dynamicCar.png").string()).size(), cv::Size(640, 480));
  EXPECT_THROW(writeEvaluationOutputs("/proc/forbidden/x", c.result, c.config, c.gt, c.det),
               std::runtime_error);
}

}  // namespace grid_vision_fusion
