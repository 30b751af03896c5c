#include "grid_vision_fusion/evaluation/evaluation_report.h"

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <stdexcept>

namespace grid_vision_fusion
{
namespace
{
namespace fs = std::filesystem;
/// Objects keep their keys in the order written, as metrics.json always had them.
using Json = nlohmann::ordered_json;

const cv::Size kPlotSize(640, 480);
const cv::Rect kPlotArea(70, 50, 540, 360);
const cv::Scalar kBlack(0, 0, 0);
const cv::Scalar kGridGrey(220, 220, 220);
const cv::Scalar kCurveBlue(200, 80, 0);
const cv::Scalar kMarkRed(0, 0, 220);

std::string number(double value, int decimals = 6)
{
  char text[64];
  std::snprintf(text, sizeof(text), "%.*f", decimals, value);
  return text;
}

/// `value` as the report's text gives it (`decimals` places) and a JSON reader reads it back:
/// the figures keep the precision they always had in metrics.json. Null when not finite.
Json jsonNumber(double value, int decimals = 6)
{
  return std::isfinite(value) ? Json(std::strtod(number(value, decimals).c_str(), nullptr)) : Json(nullptr);
}

Json jsonArray(const std::vector<double>& values)
{
  Json out = Json::array();
  for (double value : values)
  {
    out.push_back(jsonNumber(value));
  }
  return out;
}

Json jsonStats(const ErrorStats& s)
{
  return {{"count", s.count},
          {"median", jsonNumber(s.median)},
          {"mean", jsonNumber(s.mean)},
          {"p90", jsonNumber(s.p90)}};
}

/// Seconds for a report table: "never" when infinite.
std::string seconds(double value)
{
  return std::isfinite(value) ? number(value, 1) : "never";
}

/// The classes of `latencies`, sorted, with "all" first.
std::vector<std::string> latencyClasses(const std::vector<DynamicLatency>& latencies)
{
  std::set<std::string> labels;
  for (const DynamicLatency& l : latencies)
  {
    labels.insert(l.label);
  }
  std::vector<std::string> classes{""};
  classes.insert(classes.end(), labels.begin(), labels.end());
  return classes;
}

/// Per class ("all" first) the time to the first dynamic verdict; null where not finite (an
/// object never reported dynamic).
Json jsonLatency(const std::vector<DynamicLatency>& latencies)
{
  Json out = Json::object();
  for (const std::string& label : latencyClasses(latencies))
  {
    const LatencyStats s = latencyStats(latencies, label);
    out[label.empty() ? "all" : label] = {{"count", s.count},
                                          {"median_s", jsonNumber(s.median_s)},
                                          {"p90_s", jsonNumber(s.p90_s)},
                                          {"worst_s", jsonNumber(s.worst_s)},
                                          {"never", s.never}};
  }
  return out;
}

/// Every moving object's latency; null when it was never reported dynamic.
Json jsonLatencyTracks(const std::vector<DynamicLatency>& latencies)
{
  Json out = Json::array();
  for (const DynamicLatency& l : latencies)
  {
    out.push_back({{"label", l.label},
                   {"track_id", l.track_id},
                   {"latency_s", l.latency_s >= 0.0 ? jsonNumber(l.latency_s) : Json(nullptr)}});
  }
  return out;
}

Json jsonCalibration(const ProbabilityCalibration& c)
{
  Json bins = Json::array();
  for (std::size_t b = 0; b < ProbabilityCalibration::kBins; ++b)
  {
    bins.push_back({{"low", jsonNumber(0.1 * static_cast<double>(b), 1)},
                    {"high", jsonNumber(0.1 * static_cast<double>(b + 1), 1)},
                    {"count", c.count[b]},
                    {"dynamic", c.dynamic[b]},
                    {"mean_p", jsonNumber(c.mean_p[b])}});
  }
  return {{"matches", c.total},
          {"brier", jsonNumber(c.brier)},
          {"expected_calibration_error", jsonNumber(c.expected_calibration_error)},
          {"bins", bins}};
}

Json jsonClass(const ClassMetrics& m)
{
  return {{"name", m.name},
          {"ground_truth", m.ground_truth},
          {"detections", m.detections},
          {"true_positives", m.true_positives},
          {"false_positives", m.false_positives},
          {"precision", jsonNumber(m.precision)},
          {"recall", jsonNumber(m.recall)},
          {"f1", jsonNumber(m.f1)},
          {"ap", jsonNumber(m.average_precision)},
          {"ignored_difficult", m.ignored_difficult},
          {"ignored_beyond_range", m.ignored_beyond_range},
          {"ignored_dont_care", m.ignored_dont_care},
          {"left_out_beyond_range", m.left_out_beyond_range},
          {"recall_curve", jsonArray(m.recall_curve)},
          {"precision_curve", jsonArray(m.precision_curve)}};
}

/// Per object class: the motion confusion and the predicted-motion counts per truth speed band.
Json jsonMotionByClass(const EvaluationResult& result)
{
  Json out = Json::object();
  for (const auto& [label, confusion] : result.motion_confusion_by_class)
  {
    Json bands_json = Json::object();
    const auto bands = result.motion_by_class_and_band.find(label);
    if (bands != result.motion_by_class_and_band.end())
    {
      for (const auto& [band, counts] : bands->second)
      {
        bands_json[toString(band)] = counts;
      }
    }
    out[label] = {{"confusion", confusion}, {"by_truth_speed_band", bands_json}};
  }
  return out;
}

Json jsonTracking(const TrackingMetrics& t)
{
  return {{"ground_truth", t.ground_truth},
          {"matches", t.matches},
          {"false_positives", t.false_positives},
          {"misses", t.misses},
          {"id_switches", t.id_switches},
          {"fragmentations", t.fragmentations},
          {"mota", jsonNumber(t.mota)},
          {"id_switches_per_100", jsonNumber(t.id_switches_per_100)},
          {"truth_tracks", t.truth_tracks},
          {"mostly_tracked", t.mostly_tracked},
          {"mostly_lost", t.mostly_lost},
          {"idtp", t.idtp},
          {"idfp", t.idfp},
          {"idfn", t.idfn},
          {"idf1", jsonNumber(t.idf1)},
          {"idp", jsonNumber(t.idp)},
          {"idr", jsonNumber(t.idr)},
          {"motion_changes", t.motion_changes},
          {"motion_flickers", t.motion_flickers},
          {"flickering_tracks", t.flickering_tracks},
          {"dynamic_latency", jsonLatency(t.dynamic_latency)},
          {"dynamic_latency_tracks", jsonLatencyTracks(t.dynamic_latency)}};
}

/// A number for a CSV field: empty when not finite.
std::string csvNumber(double value, int decimals)
{
  return std::isfinite(value) ? number(value, decimals) : "";
}

/// An identity for a CSV field: empty when unknown (negative).
std::string idField(std::int64_t id)
{
  return id < 0 ? "" : std::to_string(id);
}

std::string percent(double fraction)
{
  return number(100.0 * fraction, 1);
}

void writeFile(const fs::path& path, const std::string& content)
{
  std::ofstream file(path);
  file << content;
  if (!file)
  {
    throw std::runtime_error("cannot write " + path.string());
  }
}

void writePng(const fs::path& path, const cv::Mat& image)
{
  if (!cv::imwrite(path.string(), image))
  {
    throw std::runtime_error("cannot write " + path.string());
  }
}

/// Canvas with a framed plot area, a title and axis labels.
cv::Mat plotCanvas(const std::string& title, const std::string& x_label, const std::string& y_label)
{
  cv::Mat canvas(kPlotSize, CV_8UC3, cv::Scalar(255, 255, 255));
  for (int i = 1; i < 10; ++i)
  {
    const int x = kPlotArea.x + kPlotArea.width * i / 10;
    const int y = kPlotArea.y + kPlotArea.height * i / 10;
    cv::line(canvas, {x, kPlotArea.y}, {x, kPlotArea.br().y}, kGridGrey);
    cv::line(canvas, {kPlotArea.x, y}, {kPlotArea.br().x, y}, kGridGrey);
  }
  cv::rectangle(canvas, kPlotArea, kBlack, 1);
  cv::putText(canvas, title, {kPlotArea.x, 30}, cv::FONT_HERSHEY_SIMPLEX, 0.6, kBlack, 1, cv::LINE_AA);
  cv::putText(canvas, x_label, {kPlotArea.x + kPlotArea.width / 2 - 40, kPlotSize.height - 20},
              cv::FONT_HERSHEY_SIMPLEX, 0.5, kBlack, 1, cv::LINE_AA);
  cv::putText(canvas, y_label, {5, kPlotArea.y - 8}, cv::FONT_HERSHEY_SIMPLEX, 0.5, kBlack, 1, cv::LINE_AA);
  return canvas;
}

void axisTicks(cv::Mat& canvas, double x_max, double y_max, int x_decimals, int y_decimals)
{
  for (int i = 0; i <= 10; i += 2)
  {
    const int x = kPlotArea.x + kPlotArea.width * i / 10;
    const int y = kPlotArea.br().y - kPlotArea.height * i / 10;
    cv::putText(canvas, number(x_max * i / 10.0, x_decimals), {x - 12, kPlotArea.br().y + 18},
                cv::FONT_HERSHEY_SIMPLEX, 0.4, kBlack, 1, cv::LINE_AA);
    cv::putText(canvas, number(y_max * i / 10.0, y_decimals), {20, y + 4}, cv::FONT_HERSHEY_SIMPLEX, 0.4,
                kBlack, 1, cv::LINE_AA);
  }
}

cv::Point toPixel(double x, double y, double x_max, double y_max)
{
  return {kPlotArea.x + static_cast<int>(std::lround(x / x_max * kPlotArea.width)),
          kPlotArea.br().y - static_cast<int>(std::lround(y / y_max * kPlotArea.height))};
}

std::string fileSafe(const std::string& name)
{
  std::string out = name;
  for (char& c : out)
  {
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '_' && c != '-')
    {
      c = '_';
    }
  }
  return out;
}

/// The reliability table of P(dynamic), when some match has one.
void calibrationMarkdown(std::ostream& out, const ProbabilityCalibration& c)
{
  if (c.total == 0)
  {
    return;
  }
  out << "\n## P(dynamic) calibration\n\nMatches with a static or dynamic truth, by the published "
         "P(dynamic): a calibrated probability has as many truly moving objects in a bin as its mean "
         "P(dynamic) says. Brier score "
      << number(c.brier, 4) << ", expected calibration error " << number(c.expected_calibration_error, 4)
      << ", " << c.total << " matches.\n\n| P(dynamic) | matches | mean P(dynamic) | truly moving [%] |\n"
      << "|---|---|---|---|\n";
  for (std::size_t b = 0; b < ProbabilityCalibration::kBins; ++b)
  {
    out << "| " << number(0.1 * static_cast<double>(b), 1) << "-"
        << number(0.1 * static_cast<double>(b + 1), 1) << " | " << c.count[b] << " | "
        << (c.count[b] ? number(c.mean_p[b], 3) : std::string("-")) << " | "
        << (c.count[b] ? percent(static_cast<double>(c.dynamic[b]) / static_cast<double>(c.count[b]))
                       : std::string("-"))
        << " |\n";
  }
}

/// The detections that are neither true nor false positives, summed over the classes (nothing
/// when there is none).
void notCountedMarkdown(std::ostream& out, const EvaluationResult& result, const EvaluationConfig& config)
{
  std::size_t difficult = 0, beyond = 0, dont_care = 0, left_out = 0;
  for (const ClassMetrics& m : result.classes)
  {
    difficult += m.ignored_difficult;
    beyond += m.ignored_beyond_range;
    dont_care += m.ignored_dont_care;
    left_out += m.left_out_beyond_range;
  }
  if (difficult + beyond + dont_care + left_out == 0)
  {
    return;
  }
  const std::string range = number(config.max_longitudinal_m, 1) + " m";
  out << "\nNot counted: " << difficult << " detections matching difficult ground truth, " << beyond
      << " matching ground truth beyond " << range << ", " << dont_care << " in DontCare regions; "
      << left_out << " beyond " << range << " matching nothing.\n";
}

}  // namespace

std::string metricsJson(const EvaluationResult& result, const EvaluationConfig& config)
{
  Json out = {{"config",
               {{"iou_threshold", jsonNumber(config.iou_threshold)},
                {"max_longitudinal_m", jsonNumber(config.max_longitudinal_m)},
                {"motion_classes", config.motion_classes}}},
              {"mAP", jsonNumber(result.mean_average_precision)}};
  Json classes = Json::array();
  for (const ClassMetrics& m : result.classes)
  {
    classes.push_back(jsonClass(m));
  }
  out["classes"] = classes;
  out["motion_confusion"] = {{"rows", "truth"},
                             {"columns", "predicted"},
                             {"labels", {"unknown", "static", "dynamic"}},
                             {"counts", result.motion_confusion}};
  out["motion_by_class"] = jsonMotionByClass(result);
  out["position_error_m"] = jsonStats(result.position_error_m);
  out["speed_error_mps"] = jsonStats(result.speed_error_mps);
  out["heading_error_rad"] = jsonStats(result.heading_error_rad);
  out["p_dynamic_calibration"] = jsonCalibration(result.p_dynamic_calibration);
  if (result.tracking)
  {
    out["tracking"] = jsonTracking(*result.tracking);
  }
  return out.dump(2, ' ', false, Json::error_handler_t::replace) + "\n";
}

std::string reportMarkdown(const EvaluationResult& result, const EvaluationConfig& config)
{
  std::ostringstream out;
  out << "# Evaluation report\n\nObjects up to " << number(config.max_longitudinal_m, 1)
      << " m ahead (ground truth farther ahead is ignored like difficult ground truth; a detection "
         "farther ahead counts only as a true positive); a true positive needs IoU >= "
      << number(config.iou_threshold, 2)
      << " (+1 pixel convention) with a ground-truth box of the same class.\n\n";
  out << "## Table I — precision, recall and F1 per class [%]\n\n"
      << "| Class | Precision | Recall | F1-score | GT | TP | FP |\n|---|---|---|---|---|---|---|\n";
  for (const auto& m : result.classes)
  {
    out << "| " << m.name << " | " << percent(m.precision) << " | " << percent(m.recall) << " | "
        << percent(m.f1) << " | " << m.ground_truth << " | " << m.true_positives << " | " << m.false_positives
        << " |\n";
  }
  notCountedMarkdown(out, result, config);
  out << "\n## Table II — average precision (VOC2012 all-point) [%]\n\n| Class | AP |\n|---|---|\n";
  for (const auto& m : result.classes)
  {
    out << "| " << m.name << " | " << percent(m.average_precision) << (m.ground_truth ? "" : " (not in GT)")
        << " |\n";
  }
  out << "| **mAP** | **" << percent(result.mean_average_precision) << "** |\n";
  static const char* const kMotion[] = {"unknown", "static", "dynamic"};
  out << "\n## Motion classification (objects matched by class and IoU)\n\n"
      << "| truth \\ predicted | unknown | static | dynamic |\n|---|---|---|---|\n";
  for (std::size_t t = 0; t < 3; ++t)
  {
    out << "| " << kMotion[t] << " | " << result.motion_confusion[t][0] << " | "
        << result.motion_confusion[t][1] << " | " << result.motion_confusion[t][2] << " |\n";
  }
  out << "\n## State errors of matched objects\n\n| quantity | count | median | mean | 90th percentile |\n"
      << "|---|---|---|---|---|\n";
  auto row = [&](const char* name, const ErrorStats& s, double scale, int decimals)
  {
    out << "| " << name << " | " << s.count << " | " << number(s.median * scale, decimals) << " | "
        << number(s.mean * scale, decimals) << " | " << number(s.p90 * scale, decimals) << " |\n";
  };
  row("position [m]", result.position_error_m, 1.0, 2);
  row("speed [m/s]", result.speed_error_mps, 1.0, 2);
  row("heading [deg] (dynamic only)", result.heading_error_rad, 180.0 / M_PI, 1);
  calibrationMarkdown(out, result.p_dynamic_calibration);
  if (result.tracking)
  {
    const TrackingMetrics& t = *result.tracking;
    out << "\n## Tracking (CLEAR MOT and identity measures, ground-truth identities: the tracklets or track "
           "ids)\n\n"
        << "| MOTA [%] | IDF1 [%] | IDP [%] | IDR [%] | GT | matched | FP | missed | ID switches | per 100 "
           "matched | fragmentations |\n|---|---|---|---|---|---|---|---|---|---|---|\n"
        << "| " << percent(t.mota) << " | " << percent(t.idf1) << " | " << percent(t.idp) << " | "
        << percent(t.idr) << " | " << t.ground_truth << " | " << t.matches << " | " << t.false_positives
        << " | " << t.misses << " | " << t.id_switches << " | " << number(t.id_switches_per_100, 2) << " | "
        << t.fragmentations << " |\n\n"
        << "| truth tracks | mostly tracked | mostly lost | motion changes (truth constant) | flickers (2 "
           "changes "
           "within the window) | flickering tracks |\n|---|---|---|---|---|---|\n"
        << "| " << t.truth_tracks << " | " << t.mostly_tracked << " | " << t.mostly_lost << " | "
        << t.motion_changes << " | " << t.motion_flickers << " | " << t.flickering_tracks << " |\n";
    out << "\n## Time to the first dynamic verdict\n\nFrom a moving object's first match (truth at the "
           "latency speed, 1 m/s by default, or "
           "more) to its first match reported dynamic [s]; \"never\": not reported dynamic while matched "
           "(counted as infinite in the percentiles).\n\n| class | objects | median | 90th percentile | "
           "worst "
           "| never |\n|---|---|---|---|---|---|\n";
    for (const std::string& label : latencyClasses(t.dynamic_latency))
    {
      const LatencyStats s = latencyStats(t.dynamic_latency, label);
      out << "| " << (label.empty() ? "all" : label) << " | " << s.count << " | " << seconds(s.median_s)
          << " | " << seconds(s.p90_s) << " | " << seconds(s.worst_s) << " | " << s.never << " |\n";
    }
  }
  return out.str();
}

std::string matchesCsv(const EvaluationResult& result)
{
  static const char* const kMotion[] = {"unknown", "static", "dynamic"};
  std::ostringstream out;
  out << "frame,label,truth_motion,predicted_motion,truth_band,truth_speed_mps,longitudinal_m,"
         "position_error_m,speed_error_mps,heading_error_rad,truth_id,track_id,p_dynamic\n";
  for (const MatchedObject& m : result.matched_objects)
  {
    out << m.frame << ',' << m.label << ',' << kMotion[static_cast<std::size_t>(m.truth_motion)] << ','
        << kMotion[static_cast<std::size_t>(m.predicted_motion)] << ',' << toString(m.band) << ','
        << number(m.truth_speed_mps, 3) << ',' << number(m.longitudinal_m, 2) << ','
        << csvNumber(m.position_error_m, 3) << ',' << csvNumber(m.speed_error_mps, 3) << ','
        << csvNumber(m.heading_error_rad, 4) << ',' << idField(m.truth_id) << ',' << idField(m.track_id)
        << ',' << (m.p_dynamic >= 0.0 ? csvNumber(m.p_dynamic, 4) : std::string()) << '\n';
  }
  return out.str();
}

void writeCartuchoFolders(const std::string& dir, const std::vector<EvalObject>& ground_truth,
                          const std::vector<EvalObject>& detections, const EvaluationConfig& config)
{
  std::map<std::string, std::string> gt_lines, det_lines;
  auto box = [](const BoundingBox& b)
  {
    return number(b.x_min, 2) + " " + number(b.y_min, 2) + " " + number(b.x_max, 2) + " " +
           number(b.y_max, 2);
  };
  for (const auto& o : ground_truth)
  {
    std::string& lines = gt_lines[o.frame];
    det_lines[o.frame];
    if (o.dont_care)
    {
      continue;
    }
    for (const std::string& name : truthClasses(o, config))  // an ignored one in each motion's class
    {
      lines += name + " " + box(o.box) + (ignoredTruth(o, config) ? " difficult" : "") + "\n";
    }
  }
  const std::vector<DetectionOutcome> outcomes = detectionOutcomes(ground_truth, detections, config);
  for (std::size_t d = 0; d < detections.size(); ++d)
  {
    const EvalObject& o = detections[d];
    std::string& lines = det_lines[o.frame];
    gt_lines[o.frame];
    if (outcomes[d] == DetectionOutcome::kTruePositive || outcomes[d] == DetectionOutcome::kFalsePositive)
    {
      lines += evaluationClass(o.label, o.motion, config.motion_classes) + " " + number(o.score) + " " +
               box(o.box) + "\n";
    }
  }
  const fs::path gt_dir = fs::path(dir) / "ground-truth";
  const fs::path det_dir = fs::path(dir) / "detection-results";
  fs::create_directories(gt_dir);
  fs::create_directories(det_dir);
  for (const auto& [frame, lines] : gt_lines)
  {
    writeFile(gt_dir / (frame + ".txt"), lines);
  }
  for (const auto& [frame, lines] : det_lines)
  {
    writeFile(det_dir / (frame + ".txt"), lines);
  }
}

cv::Mat drawPrCurve(const ClassMetrics& metrics)
{
  cv::Mat canvas = plotCanvas(metrics.name + ": AP = " + number(100.0 * metrics.average_precision, 1) + " %",
                              "recall", "precision");
  axisTicks(canvas, 1.0, 1.0, 1, 1);
  std::vector<cv::Point> curve{
      toPixel(0.0, metrics.precision_curve.empty() ? 0.0 : metrics.precision_curve[0], 1, 1)};
  for (std::size_t i = 0; i < metrics.recall_curve.size(); ++i)
  {
    curve.push_back(toPixel(metrics.recall_curve[i], metrics.precision_curve[i], 1.0, 1.0));
  }
  cv::polylines(canvas, curve, false, kCurveBlue, 2, cv::LINE_AA);
  return canvas;
}

cv::Mat drawHistogram(const ErrorStats& stats, const std::string& title, const std::string& unit, int bins)
{
  if (bins < 1)
  {
    throw std::invalid_argument("a histogram needs at least one bin");
  }
  cv::Mat canvas = plotCanvas(title + " (n = " + std::to_string(stats.count) + ")", unit, "count");
  const double x_max = stats.values.empty() ? 1.0 : std::max(stats.values.back(), 1e-9);
  std::vector<int> counts(static_cast<std::size_t>(bins), 0);
  for (double v : stats.values)
  {
    const auto bin = std::min(static_cast<std::size_t>(v / x_max * bins), counts.size() - 1);
    ++counts[bin];
  }
  const double y_max = std::ceil(std::max(1, *std::max_element(counts.begin(), counts.end())) * 1.1);
  axisTicks(canvas, x_max, y_max, 2, y_max < 10.0 ? 1 : 0);
  if (stats.count == 0)
  {
    cv::putText(canvas, "no data",
                {kPlotArea.x + kPlotArea.width / 2 - 40, kPlotArea.y + kPlotArea.height / 2},
                cv::FONT_HERSHEY_SIMPLEX, 0.8, kMarkRed, 2, cv::LINE_AA);
  }
  for (int b = 0; b < bins; ++b)
  {
    if (counts[static_cast<std::size_t>(b)] == 0)
    {
      continue;
    }
    const cv::Point top_left = toPixel(x_max * b / bins, counts[static_cast<std::size_t>(b)], x_max, y_max);
    const cv::Point bottom_right = toPixel(x_max * (b + 1) / bins, 0.0, x_max, y_max);
    cv::rectangle(canvas, top_left, bottom_right - cv::Point(1, 0), kCurveBlue, cv::FILLED);
  }
  if (stats.count > 0)
  {
    for (const auto& [value, name] :
         {std::make_pair(stats.median, "median"), std::make_pair(stats.p90, "p90")})
    {
      const cv::Point bottom = toPixel(value, 0.0, x_max, y_max);
      cv::line(canvas, bottom, {bottom.x, kPlotArea.y}, kMarkRed, 1, cv::LINE_AA);
      cv::putText(canvas, std::string(name) + " " + number(value, 2), {bottom.x + 4, kPlotArea.y + 15},
                  cv::FONT_HERSHEY_SIMPLEX, 0.45, kMarkRed, 1, cv::LINE_AA);
    }
  }
  return canvas;
}

void writeEvaluationOutputs(const std::string& dir, const EvaluationResult& result,
                            const EvaluationConfig& config, const std::vector<EvalObject>& ground_truth,
                            const std::vector<EvalObject>& detections)
{
  const fs::path out(dir);
  std::error_code error;
  fs::create_directories(out, error);
  if (error)
  {
    throw std::runtime_error("cannot create output folder " + dir + ": " + error.message());
  }
  writeFile(out / "metrics.json", metricsJson(result, config));
  writeFile(out / "report.md", reportMarkdown(result, config));
  writeFile(out / "matches.csv", matchesCsv(result));
  writeCartuchoFolders(dir, ground_truth, detections, config);
  for (const auto& m : result.classes)
  {
    writePng(out / ("pr_" + fileSafe(m.name) + ".png"), drawPrCurve(m));
  }
  writePng(out / "hist_position.png", drawHistogram(result.position_error_m, "position error", "m"));
  writePng(out / "hist_speed.png", drawHistogram(result.speed_error_mps, "speed error", "m/s"));
  ErrorStats heading_deg = result.heading_error_rad;
  for (double* v : {&heading_deg.median, &heading_deg.mean, &heading_deg.p90})
  {
    *v *= 180.0 / M_PI;
  }
  for (double& v : heading_deg.values)
  {
    v *= 180.0 / M_PI;
  }
  writePng(out / "hist_heading.png", drawHistogram(heading_deg, "heading error (dynamic)", "deg"));
}

}  // namespace grid_vision_fusion
