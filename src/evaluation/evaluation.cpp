#include "grid_vision_fusion/evaluation/evaluation.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <limits>
#include <numeric>
#include <set>
#include <stdexcept>

namespace grid_vision_fusion
{
namespace
{
/// A detection's match against the ground truth of its class.
struct Match
{
  DetectionOutcome kind = DetectionOutcome::kFalsePositive;
  std::size_t truth = 0;  ///< index into the ground-truth list when a true positive
};

double wrapAngle(double angle)
{
  angle = std::fmod(angle + M_PI, 2.0 * M_PI);
  if (angle < 0.0)
  {
    angle += 2.0 * M_PI;
  }
  return angle - M_PI;
}

/// Cartucho/mAP greedy matching of the detections `det_indices` (any order) against the
/// ground truth `gt_indices`, both already restricted to one class, with the range limit and
/// the DontCare regions of the file comment. Returns one Match per detection, in descending
/// score order (stable), together with that order.
std::vector<std::pair<std::size_t, Match>> greedyMatch(const std::vector<EvalObject>& ground_truth,
                                                       const std::vector<std::size_t>& gt_indices,
                                                       const std::vector<EvalObject>& detections,
                                                       std::vector<std::size_t> det_indices,
                                                       const EvaluationConfig& config,
                                                       const DontCareRegions& dont_care)
{
  std::stable_sort(det_indices.begin(), det_indices.end(),
                   [&](std::size_t a, std::size_t b) { return detections[a].score > detections[b].score; });
  std::map<std::string, std::vector<std::size_t>> gt_by_frame;
  for (std::size_t g : gt_indices)
  {
    gt_by_frame[ground_truth[g].frame].push_back(g);
  }
  std::vector<bool> used(ground_truth.size(), false);
  std::vector<std::pair<std::size_t, Match>> matches;
  matches.reserve(det_indices.size());
  for (std::size_t d : det_indices)
  {
    double best_iou = -1.0;
    std::size_t best = 0;
    const auto frame = gt_by_frame.find(detections[d].frame);
    if (frame != gt_by_frame.end())
    {
      for (std::size_t g : frame->second)
      {
        const double iou = boxIou(detections[d].box, ground_truth[g].box);
        if (iou > best_iou)
        {
          best_iou = iou;
          best = g;
        }
      }
    }
    Match match;
    if (best_iou >= config.iou_threshold)
    {
      if (!inRange(ground_truth[best], config.max_longitudinal_m))
      {
        match.kind = DetectionOutcome::kIgnoredBeyondRange;
      }
      else if (ground_truth[best].difficult)
      {
        match.kind = DetectionOutcome::kIgnoredDifficult;
      }
      else if (!used[best])
      {
        used[best] = true;
        match.kind = DetectionOutcome::kTruePositive;
        match.truth = best;
      }
    }
    if (match.kind != DetectionOutcome::kTruePositive && !inRange(detections[d], config.max_longitudinal_m))
    {
      match.kind = DetectionOutcome::kLeftOutBeyondRange;
    }
    else if (match.kind == DetectionOutcome::kFalsePositive &&
             inDontCare(dont_care, detections[d].frame, detections[d].box, config.iou_threshold))
    {
      match.kind = DetectionOutcome::kIgnoredDontCare;
    }
    matches.emplace_back(d, match);
  }
  return matches;
}

/// The ground truth and detections of every evaluation class, and the DontCare regions.
struct ClassLists
{
  std::map<std::string, std::vector<std::size_t>> gt_of, det_of;
  std::set<std::string> gt_classes;  ///< classes with counted (non-difficult, in range) ground truth
  DontCareRegions dont_care;
};

ClassLists classLists(const std::vector<EvalObject>& ground_truth, const std::vector<EvalObject>& detections,
                      const EvaluationConfig& config)
{
  ClassLists lists;
  for (std::size_t g = 0; g < ground_truth.size(); ++g)
  {
    const EvalObject& o = ground_truth[g];
    if (o.dont_care)
    {
      lists.dont_care[o.frame].push_back(o.box);
      continue;
    }
    for (const std::string& name : truthClasses(o, config))
    {
      lists.gt_of[name].push_back(g);
    }
    if (!ignoredTruth(o, config))
    {
      lists.gt_classes.insert(evaluationClass(o.label, o.motion, config.motion_classes));
    }
  }
  for (std::size_t d = 0; d < detections.size(); ++d)
  {
    lists.det_of[evaluationClass(detections[d].label, detections[d].motion, config.motion_classes)].push_back(
        d);
  }
  return lists;
}

/// Counts `match` into the figures of its class (the PR curve point of a counted detection).
void countMatch(const Match& match, ClassMetrics& metrics)
{
  switch (match.kind)
  {
    case DetectionOutcome::kIgnoredDifficult:
      ++metrics.ignored_difficult;
      return;
    case DetectionOutcome::kIgnoredBeyondRange:
      ++metrics.ignored_beyond_range;
      return;
    case DetectionOutcome::kIgnoredDontCare:
      ++metrics.ignored_dont_care;
      return;
    case DetectionOutcome::kLeftOutBeyondRange:
      ++metrics.left_out_beyond_range;
      return;
    case DetectionOutcome::kTruePositive:
      ++metrics.true_positives;
      break;
    case DetectionOutcome::kFalsePositive:
      ++metrics.false_positives;
      break;
  }
  ++metrics.detections;
  const double tp = static_cast<double>(metrics.true_positives);
  metrics.recall_curve.push_back(metrics.ground_truth > 0 ? tp / static_cast<double>(metrics.ground_truth)
                                                          : 0.0);
  metrics.precision_curve.push_back(tp / static_cast<double>(metrics.detections));
}
}  // namespace

bool inRange(const EvalObject& object, double max_longitudinal_m)
{
  return object.longitudinal_m <= max_longitudinal_m;
}

bool inDontCare(const DontCareRegions& regions, const std::string& frame, const BoundingBox& box,
                double overlap)
{
  const auto found = regions.find(frame);
  if (found == regions.end())
  {
    return false;
  }
  const double area = (box.x_max - box.x_min + 1.0) * (box.y_max - box.y_min + 1.0);
  for (const BoundingBox& region : found->second)
  {
    const double iw = std::min(box.x_max, region.x_max) - std::max(box.x_min, region.x_min) + 1.0;
    const double ih = std::min(box.y_max, region.y_max) - std::max(box.y_min, region.y_min) + 1.0;
    if (iw > 0.0 && ih > 0.0 && area > 0.0 && iw * ih / area >= overlap)
    {
      return true;
    }
  }
  return false;
}

void EvaluationConfig::validate() const
{
  if (!(iou_threshold > 0.0 && iou_threshold <= 1.0))
  {
    throw std::invalid_argument("iou_threshold must be in (0, 1], got " + std::to_string(iou_threshold));
  }
  if (!(max_longitudinal_m > 0.0))
  {
    throw std::invalid_argument("max_longitudinal_m must be > 0, got " + std::to_string(max_longitudinal_m));
  }
}

std::string toString(SpeedBand band)
{
  switch (band)
  {
    case SpeedBand::kStatic:
      return "static";
    case SpeedBand::kBelow1:
      return "0.5-1";
    case SpeedBand::k1To3:
      return "1-3";
    case SpeedBand::kAbove3:
      return ">3";
    case SpeedBand::kUnknown:
      break;
  }
  return "unknown";
}

SpeedBand speedBandOf(Motion truth_motion, bool has_state, double truth_speed_mps)
{
  if (truth_motion == Motion::kStatic)
  {
    return SpeedBand::kStatic;
  }
  if (truth_motion != Motion::kDynamic || !has_state || !std::isfinite(truth_speed_mps))
  {
    return SpeedBand::kUnknown;
  }
  if (truth_speed_mps < 1.0)
  {
    return SpeedBand::kBelow1;
  }
  return truth_speed_mps < 3.0 ? SpeedBand::k1To3 : SpeedBand::kAbove3;
}

std::string evaluationClass(const std::string& label, Motion motion, bool with_motion)
{
  if (!with_motion)
  {
    return label;
  }
  std::string name = label;
  if (!name.empty())
  {
    name[0] = static_cast<char>(std::toupper(static_cast<unsigned char>(name[0])));
  }
  return toString(motion) + name;
}

double boxIou(const BoundingBox& a, const BoundingBox& b)
{
  const double iw = std::min(a.x_max, b.x_max) - std::max(a.x_min, b.x_min) + 1.0;
  const double ih = std::min(a.y_max, b.y_max) - std::max(a.y_min, b.y_min) + 1.0;
  if (iw <= 0.0 || ih <= 0.0)
  {
    return 0.0;
  }
  const double area_a = (a.x_max - a.x_min + 1.0) * (a.y_max - a.y_min + 1.0);
  const double area_b = (b.x_max - b.x_min + 1.0) * (b.y_max - b.y_min + 1.0);
  return iw * ih / (area_a + area_b - iw * ih);
}

double vocAveragePrecision(const std::vector<double>& recall, const std::vector<double>& precision)
{
  if (recall.size() != precision.size())
  {
    throw std::invalid_argument("recall and precision curves differ in length");
  }
  if (recall.empty())
  {
    return 0.0;
  }
  std::vector<double> mrec{0.0};
  mrec.insert(mrec.end(), recall.begin(), recall.end());
  mrec.push_back(1.0);
  std::vector<double> mpre{0.0};
  mpre.insert(mpre.end(), precision.begin(), precision.end());
  mpre.push_back(0.0);
  // Precision envelope: monotonically decreasing from the right.
  for (std::size_t i = mpre.size() - 1; i-- > 0;)
  {
    mpre[i] = std::max(mpre[i], mpre[i + 1]);
  }
  double ap = 0.0;
  for (std::size_t i = 1; i < mrec.size(); ++i)
  {
    if (mrec[i] != mrec[i - 1])
    {
      ap += (mrec[i] - mrec[i - 1]) * mpre[i];
    }
  }
  return ap;
}

LatencyStats latencyStats(const std::vector<DynamicLatency>& latencies, const std::string& label)
{
  std::vector<double> values;
  LatencyStats stats;
  for (const DynamicLatency& l : latencies)
  {
    if (label.empty() || l.label == label)
    {
      values.push_back(l.latency_s >= 0.0 ? l.latency_s : std::numeric_limits<double>::infinity());
      stats.never += l.latency_s >= 0.0 ? 0 : 1;
    }
  }
  if (values.empty())
  {
    return stats;
  }
  stats.count = values.size();
  stats.worst_s = *std::max_element(values.begin(), values.end());
  // Nearest rank, so that an object never reported dynamic gives +infinity rather than NaN.
  std::sort(values.begin(), values.end());
  auto rank = [&](double q)
  { return values[std::min(values.size() - 1, static_cast<std::size_t>(std::ceil(q * values.size())) - 1)]; };
  stats.median_s = rank(0.5);
  stats.p90_s = rank(0.9);
  return stats;
}

ErrorStats errorStats(std::vector<double> values)
{
  ErrorStats stats;
  stats.count = values.size();
  if (values.empty())
  {
    return stats;
  }
  std::sort(values.begin(), values.end());
  stats.mean = std::accumulate(values.begin(), values.end(), 0.0) / static_cast<double>(values.size());
  auto quantile = [&](double q)
  {
    const double rank = q * static_cast<double>(values.size() - 1);
    const auto lower = static_cast<std::size_t>(std::floor(rank));
    const std::size_t upper = std::min(lower + 1, values.size() - 1);
    return values[lower] + (rank - static_cast<double>(lower)) * (values[upper] - values[lower]);
  };
  stats.median = quantile(0.5);
  stats.p90 = quantile(0.9);
  stats.values = std::move(values);
  return stats;
}

namespace
{
/// Precision, recall, F1 and AP of one class from its counted matches.
ClassMetrics classMetrics(const std::string& name, const std::vector<EvalObject>& ground_truth,
                          const std::vector<EvalObject>& detections, const ClassLists& lists,
                          const EvaluationConfig& config)
{
  ClassMetrics metrics;
  metrics.name = name;
  static const std::vector<std::size_t> kNone;
  const auto gts = lists.gt_of.find(name);
  const auto dets = lists.det_of.find(name);
  const std::vector<std::size_t>& gt_indices = gts == lists.gt_of.end() ? kNone : gts->second;
  metrics.ground_truth = static_cast<std::size_t>(
      std::count_if(gt_indices.begin(), gt_indices.end(),
                    [&](std::size_t g) { return !ignoredTruth(ground_truth[g], config); }));
  for (const auto& [d, match] :
       greedyMatch(ground_truth, gt_indices, detections, dets == lists.det_of.end() ? kNone : dets->second,
                   config, lists.dont_care))
  {
    (void)d;
    countMatch(match, metrics);
  }
  if (metrics.detections > 0)
  {
    metrics.precision = static_cast<double>(metrics.true_positives) / static_cast<double>(metrics.detections);
  }
  if (metrics.ground_truth > 0)
  {
    metrics.recall = static_cast<double>(metrics.true_positives) / static_cast<double>(metrics.ground_truth);
    metrics.average_precision = vocAveragePrecision(metrics.recall_curve, metrics.precision_curve);
  }
  if (metrics.precision + metrics.recall > 0.0)
  {
    metrics.f1 = 2.0 * metrics.precision * metrics.recall / (metrics.precision + metrics.recall);
  }
  return metrics;
}

/// One true positive of the class-only matching into the motion and state figures of `result`.
void addMatchedObject(const EvalObject& gt, const EvalObject& det, const std::string& label,
                      EvaluationResult& result, std::vector<double>& position_errors,
                      std::vector<double>& speed_errors, std::vector<double>& heading_errors)
{
  const auto truth_index = static_cast<std::size_t>(gt.motion);
  const auto predicted_index = static_cast<std::size_t>(det.motion);
  ++result.motion_confusion[truth_index][predicted_index];
  ++result.motion_confusion_by_class[label][truth_index][predicted_index];
  MatchedObject matched;
  matched.frame = gt.frame;
  matched.label = label;
  matched.truth_motion = gt.motion;
  matched.predicted_motion = det.motion;
  matched.truth_speed_mps = gt.has_state ? std::hypot(gt.vx, gt.vy) : 0.0;
  matched.band = speedBandOf(gt.motion, gt.has_state, matched.truth_speed_mps);
  matched.longitudinal_m = gt.longitudinal_m;
  matched.truth_id = gt.track_id;
  matched.track_id = det.track_id;
  matched.p_dynamic = det.p_dynamic;
  matched.has_state = det.has_state && gt.has_state;
  matched.position_error_m = std::nan("");
  matched.speed_error_mps = std::nan("");
  matched.heading_error_rad = std::nan("");
  ++result.motion_by_class_and_band[label][matched.band][predicted_index];
  if (matched.has_state)
  {
    matched.position_error_m = std::hypot(det.x - gt.x, det.y - gt.y);
    matched.speed_error_mps = std::abs(std::hypot(det.vx, det.vy) - matched.truth_speed_mps);
    position_errors.push_back(matched.position_error_m);
    speed_errors.push_back(matched.speed_error_mps);
    if (det.motion == Motion::kDynamic && gt.motion == Motion::kDynamic)
    {
      matched.heading_error_rad = std::abs(wrapAngle(std::atan2(det.vy, det.vx) - std::atan2(gt.vy, gt.vx)));
      heading_errors.push_back(matched.heading_error_rad);
    }
  }
  result.matched_objects.push_back(std::move(matched));
}

/// Motion and state errors: the ground truth and detections matched by object class alone,
/// whatever the motion (the same rules, true positives only).
void addMotionAndStateFigures(const std::vector<EvalObject>& ground_truth,
                              const std::vector<EvalObject>& detections, const ClassLists& lists,
                              const EvaluationConfig& config, EvaluationResult& result)
{
  std::map<std::string, std::vector<std::size_t>> gt_by_label, det_by_label;
  for (std::size_t g = 0; g < ground_truth.size(); ++g)
  {
    if (!ground_truth[g].dont_care)
    {
      gt_by_label[ground_truth[g].label].push_back(g);
    }
  }
  for (const auto& [name, indices] : lists.det_of)
  {
    (void)name;
    for (std::size_t d : indices)
    {
      det_by_label[detections[d].label].push_back(d);
    }
  }
  std::vector<double> position_errors, speed_errors, heading_errors;
  for (const auto& [label, dets] : det_by_label)
  {
    for (const auto& [d, match] :
         greedyMatch(ground_truth, gt_by_label[label], detections, dets, config, lists.dont_care))
    {
      if (match.kind == DetectionOutcome::kTruePositive)
      {
        addMatchedObject(ground_truth[match.truth], detections[d], label, result, position_errors,
                         speed_errors, heading_errors);
      }
    }
  }
  result.position_error_m = errorStats(std::move(position_errors));
  result.speed_error_mps = errorStats(std::move(speed_errors));
  result.heading_error_rad = errorStats(std::move(heading_errors));
}
}  // namespace

bool ignoredTruth(const EvalObject& truth, const EvaluationConfig& config)
{
  return truth.difficult || !inRange(truth, config.max_longitudinal_m);
}

std::vector<std::string> truthClasses(const EvalObject& truth, const EvaluationConfig& config)
{
  std::vector<std::string> names{evaluationClass(truth.label, truth.motion, config.motion_classes)};
  const bool unscored = !inRange(truth, config.max_longitudinal_m) || truth.motion == Motion::kUnknown;
  if (config.motion_classes && ignoredTruth(truth, config) && unscored)
  {
    for (const Motion motion : {Motion::kUnknown, Motion::kStatic, Motion::kDynamic})
    {
      if (motion != truth.motion)
      {
        names.push_back(evaluationClass(truth.label, motion, true));
      }
    }
  }
  return names;
}

std::string toString(DetectionOutcome outcome)
{
  switch (outcome)
  {
    case DetectionOutcome::kTruePositive:
      return "true_positive";
    case DetectionOutcome::kFalsePositive:
      return "false_positive";
    case DetectionOutcome::kIgnoredDifficult:
      return "ignored_difficult";
    case DetectionOutcome::kIgnoredBeyondRange:
      return "ignored_beyond_range";
    case DetectionOutcome::kIgnoredDontCare:
      return "ignored_dont_care";
    case DetectionOutcome::kLeftOutBeyondRange:
      break;
  }
  return "left_out_beyond_range";
}

std::vector<DetectionOutcome> detectionOutcomes(const std::vector<EvalObject>& ground_truth,
                                                const std::vector<EvalObject>& detections,
                                                const EvaluationConfig& config)
{
  config.validate();
  const ClassLists lists = classLists(ground_truth, detections, config);
  std::vector<DetectionOutcome> outcomes(detections.size(), DetectionOutcome::kFalsePositive);
  static const std::vector<std::size_t> kNone;
  for (const auto& [name, dets] : lists.det_of)
  {
    const auto gts = lists.gt_of.find(name);
    for (const auto& [d, match] : greedyMatch(ground_truth, gts == lists.gt_of.end() ? kNone : gts->second,
                                              detections, dets, config, lists.dont_care))
    {
      outcomes[d] = match.kind;
    }
  }
  return outcomes;
}

EvaluationResult evaluate(const std::vector<EvalObject>& ground_truth,
                          const std::vector<EvalObject>& detections, const EvaluationConfig& config)
{
  config.validate();
  EvaluationResult result;
  const ClassLists lists = classLists(ground_truth, detections, config);
  std::set<std::string> names(lists.gt_classes);
  for (const auto& entry : lists.det_of)
  {
    names.insert(entry.first);
  }
  double ap_sum = 0.0;
  for (const std::string& name : names)
  {
    ClassMetrics metrics = classMetrics(name, ground_truth, detections, lists, config);
    const auto dets = lists.det_of.find(name);
    if (lists.gt_classes.count(name) == 0 && dets != lists.det_of.end() &&
        metrics.left_out_beyond_range == dets->second.size())
    {
      continue;  // only detections beyond the range limit that match nothing: not a class here
    }
    if (lists.gt_classes.count(name) > 0)
    {
      ap_sum += metrics.average_precision;
    }
    result.classes.push_back(std::move(metrics));
  }
  std::stable_partition(result.classes.begin(), result.classes.end(),
                        [&](const ClassMetrics& m) { return lists.gt_classes.count(m.name) > 0; });
  if (!lists.gt_classes.empty())
  {
    result.mean_average_precision = ap_sum / static_cast<double>(lists.gt_classes.size());
  }
  addMotionAndStateFigures(ground_truth, detections, lists, config, result);
  result.p_dynamic_calibration = probabilityCalibration(result.matched_objects);
  return result;
}

ProbabilityCalibration probabilityCalibration(const std::vector<MatchedObject>& matches)
{
  ProbabilityCalibration c;
  std::array<double, ProbabilityCalibration::kBins> p_sum{};
  double squared_error_sum = 0.0;
  for (const MatchedObject& m : matches)
  {
    const bool known = m.truth_motion == Motion::kStatic || m.truth_motion == Motion::kDynamic;
    if (!known || !(m.p_dynamic >= 0.0 && m.p_dynamic <= 1.0))
    {
      continue;
    }
    const auto bin = std::min(static_cast<std::size_t>(m.p_dynamic * ProbabilityCalibration::kBins),
                              ProbabilityCalibration::kBins - 1);
    const bool moving = m.truth_motion == Motion::kDynamic;
    const double truth = moving ? 1.0 : 0.0;
    ++c.count[bin];
    c.dynamic[bin] += moving ? 1 : 0;
    p_sum[bin] += m.p_dynamic;
    squared_error_sum += (m.p_dynamic - truth) * (m.p_dynamic - truth);
    ++c.total;
  }
  if (c.total == 0)
  {
    return c;
  }
  c.brier = squared_error_sum / static_cast<double>(c.total);
  for (std::size_t b = 0; b < ProbabilityCalibration::kBins; ++b)
  {
    if (c.count[b] == 0)
    {
      continue;
    }
    const auto n = static_cast<double>(c.count[b]);
    c.mean_p[b] = p_sum[b] / n;
    c.expected_calibration_error +=
        n / static_cast<double>(c.total) * std::abs(c.mean_p[b] - static_cast<double>(c.dynamic[b]) / n);
  }
  return c;
}

}  // namespace grid_vision_fusion
