#include "grid_vision_fusion/evaluation/evaluation.h"

#include <algorithm>
#include <cctype>
#include <cmath>
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
  enum Kind
  {
    kTruePositive,
    kFalsePositive,
    kIgnored,
  } kind = kFalsePositive;
  std::size_t truth = 0;  ///< index into the ground-truth list when kTruePositive
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
/// ground truth `gt_indices`, both already restricted to one class. Returns one Match per
/// detection, in descending score order (stable), together with that order.
std::vector<std::pair<std::size_t, Match>> greedyMatch(const std::vector<EvalObject>& ground_truth,
                                                       const std::vector<std::size_t>& gt_indices,
                                                       const std::vector<EvalObject>& detections,
                                                       std::vector<std::size_t> det_indices,
                                                       double iou_threshold)
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
    if (best_iou >= iou_threshold)
    {
      if (ground_truth[best].difficult)
      {
        match.kind = Match::kIgnored;
      }
      else if (!used[best])
      {
        used[best] = true;
        match.kind = Match::kTruePositive;
        match.truth = best;
      }
    }
    matches.emplace_back(d, match);
  }
  return matches;
}

bool inRange(const EvalObject& object, const EvaluationConfig& config)
{
  return object.longitudinal_m <= config.max_longitudinal_m;
}
}  // namespace

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

EvaluationResult evaluate(const std::vector<EvalObject>& ground_truth,
                          const std::vector<EvalObject>& detections, const EvaluationConfig& config)
{
  config.validate();
  EvaluationResult result;

  // Per evaluation class: the in-range ground truth and detections.
  std::map<std::string, std::vector<std::size_t>> gt_of, det_of;
  std::set<std::string> gt_classes;
  for (std::size_t g = 0; g < ground_truth.size(); ++g)
  {
    if (!inRange(ground_truth[g], config))
    {
      continue;
    }
    const std::string name =
        evaluationClass(ground_truth[g].label, ground_truth[g].motion, config.motion_classes);
    gt_of[name].push_back(g);
    if (!ground_truth[g].difficult)
    {
      gt_classes.insert(name);
    }
  }
  for (std::size_t d = 0; d < detections.size(); ++d)
  {
    if (inRange(detections[d], config))
    {
      det_of[evaluationClass(detections[d].label, detections[d].motion, config.motion_classes)].push_back(d);
    }
  }
  std::set<std::string> names(gt_classes);
  for (const auto& entry : det_of)
  {
    names.insert(entry.first);
  }

  double ap_sum = 0.0;
  for (const std::string& name : names)
  {
    ClassMetrics metrics;
    metrics.name = name;
    const std::vector<std::size_t>& gts = gt_of[name];
    metrics.ground_truth = static_cast<std::size_t>(
        std::count_if(gts.begin(), gts.end(), [&](std::size_t g) { return !ground_truth[g].difficult; }));
    for (const auto& [d, match] :
         greedyMatch(ground_truth, gts, detections, det_of[name], config.iou_threshold))
    {
      (void)d;
      if (match.kind == Match::kIgnored)
      {
        continue;
      }
      ++metrics.detections;
      if (match.kind == Match::kTruePositive)
      {
        ++metrics.true_positives;
      }
      else
      {
        ++metrics.false_positives;
      }
      const double tp = static_cast<double>(metrics.true_positives);
      metrics.recall_curve.push_back(metrics.ground_truth > 0 ? tp / static_cast<double>(metrics.ground_truth)
                                                              : 0.0);
      metrics.precision_curve.push_back(tp / static_cast<double>(metrics.detections));
    }
    if (metrics.detections > 0)
    {
      metrics.precision =
          static_cast<double>(metrics.true_positives) / static_cast<double>(metrics.detections);
    }
    if (metrics.ground_truth > 0)
    {
      metrics.recall =
          static_cast<double>(metrics.true_positives) / static_cast<double>(metrics.ground_truth);
      metrics.average_precision = vocAveragePrecision(metrics.recall_curve, metrics.precision_curve);
    }
    if (metrics.precision + metrics.recall > 0.0)
    {
      metrics.f1 = 2.0 * metrics.precision * metrics.recall / (metrics.precision + metrics.recall);
    }
    if (gt_classes.count(name) > 0)
    {
      ap_sum += metrics.average_precision;
    }
    result.classes.push_back(std::move(metrics));
  }
  std::stable_partition(result.classes.begin(), result.classes.end(),
                        [&](const ClassMetrics& m) { return gt_classes.count(m.name) > 0; });
  if (!gt_classes.empty())
  {
    result.mean_average_precision = ap_sum / static_cast<double>(gt_classes.size());
  }

  // Motion and state errors: match by object class alone, whatever the motion.
  std::map<std::string, std::vector<std::size_t>> gt_by_label, det_by_label;
  for (const auto& [name, indices] : gt_of)
  {
    (void)name;
    for (std::size_t g : indices)
    {
      gt_by_label[ground_truth[g].label].push_back(g);
    }
  }
  for (const auto& [name, indices] : det_of)
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
         greedyMatch(ground_truth, gt_by_label[label], detections, dets, config.iou_threshold))
    {
      if (match.kind != Match::kTruePositive)
      {
        continue;
      }
      const EvalObject& det = detections[d];
      const EvalObject& gt = ground_truth[match.truth];
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
          matched.heading_error_rad =
              std::abs(wrapAngle(std::atan2(det.vy, det.vx) - std::atan2(gt.vy, gt.vx)));
          heading_errors.push_back(matched.heading_error_rad);
        }
      }
      result.matched_objects.push_back(std::move(matched));
    }
  }
  result.position_error_m = errorStats(std::move(position_errors));
  result.speed_error_mps = errorStats(std::move(speed_errors));
  result.heading_error_rad = errorStats(std::move(heading_errors));
  return result;
}

}  // namespace grid_vision_fusion
