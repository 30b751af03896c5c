// Evaluation like the paper (P/R/F1 per motion x class, Pascal VOC AP, mAP within a range) and
// beyond it (motion confusion, position, speed and heading errors of matched objects).
//
// The matching follows the Cartucho/mAP tool (github.com/Cartucho/mAP, main.py) so that its
// figures can be cross-checked with it: per class, detections sorted by descending score
// (stable: ties keep the input order); each takes the ground truth of the same class and frame
// with the largest IoU, used or not; IoU >= threshold and unused -> TP (the ground truth becomes
// used), used -> FP (no fallback to the second best), a difficult ground truth -> ignored;
// IoU below the threshold -> FP. IoU with the "+1 pixel" convention. AP = VOC2012 all-point
// interpolation; mAP = mean AP over the classes present in the (non-difficult) ground truth.
//
// The range limit and the DontCare regions as the KITTI benchmark treats what it does not score
// (devkit cpp/evaluate_object.cpp, evaluate_tracking.py): ground truth farther ahead than the
// limit is ignored like difficult ground truth (a detection whose best match it is counts
// neither as a true nor as a false positive, and it is never a miss); it, and ignored ground
// truth of unknown motion, is matched in the class of every motion of its object class
// (truthClasses()), so that a detection of it reporting any motion is ignored; a detection
// farther ahead than the limit counts only when it is a true positive (else it is left out); a
// detection that would be a false positive and lies in a DontCare region (intersection / its
// own area >= the IoU threshold) is ignored.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "grid_vision_fusion/fusion/fusion.h"

namespace grid_vision_fusion
{
/// A ground-truth or detected object in one frame.
struct EvalObject
{
  std::string frame;  ///< frame identifier (e.g. "000042"); matching happens within a frame
  std::string label;  ///< object class, e.g. "car"
  Motion motion = Motion::kUnknown;
  BoundingBox box;              ///< 2-D box in the image [px]
  float score = 1.F;            ///< detector confidence (1 for ground truth)
  bool difficult = false;       ///< ground truth only: ignored by the matching
  double longitudinal_m = 0.0;  ///< distance ahead of the ego vehicle [m], for the range filter
  bool has_state = false;       ///< position/velocity below are valid
  double x = 0.0, y = 0.0;      ///< position [m] (world frame)
  double vx = 0.0, vy = 0.0;    ///< velocity [m/s] (world frame)
  /// Identity across frames: the tracklet (or the tracking labels' track_id) of a ground-truth
  /// object, DetectedObject.id of a detection; −1 when unknown (label files). Only the tracking
  /// metrics use it.
  std::int64_t track_id = -1;
  double time_s = 0.0;  ///< time of the frame [s] (the tracking metrics' flicker window)
  /// A detection's probability that it moves (DetectedObject.p_dynamic), [0, 1]; negative when
  /// not given (label files, ground truth).
  double p_dynamic = -1.0;
  /// Ground truth only: a KITTI DontCare region (its box), not an object: a detection of any
  /// class that would be a false positive and lies in it (intersection / detection area >= the
  /// IoU threshold) is ignored. Its label, motion and range play no part.
  bool dont_care = false;
};

/// Parameters of evaluate().
struct EvaluationConfig
{
  double iou_threshold = 0.5;  ///< minimum IoU of a true positive, (0, 1]
  /// Range limit [m], > 0: ground truth farther ahead is ignored (as difficult), detections
  /// farther ahead count only as true positives (see the file comment).
  double max_longitudinal_m = 30.0;
  /// Evaluate per motion x class ("dynamicCar"); false: per class only ("car").
  bool motion_classes = true;

  /// @throws std::invalid_argument naming the bad field.
  void validate() const;
};

/// Figures of one evaluation class.
struct ClassMetrics
{
  std::string name;
  std::size_t ground_truth = 0;  ///< non-difficult ground-truth objects
  std::size_t detections = 0;    ///< detections counted (not ignored)
  std::size_t true_positives = 0;
  std::size_t false_positives = 0;
  /// Detections not counted (DetectionOutcome): best match a difficult ground truth, best match
  /// a ground truth beyond the range limit, in a DontCare region, beyond the limit themselves.
  std::size_t ignored_difficult = 0;
  std::size_t ignored_beyond_range = 0;
  std::size_t ignored_dont_care = 0;
  std::size_t left_out_beyond_range = 0;
  double precision = 0.0;  ///< at the operating point (all detections)
  double recall = 0.0;
  double f1 = 0.0;
  double average_precision = 0.0;
  std::vector<double> recall_curve;  ///< cumulative, one point per counted detection
  std::vector<double> precision_curve;
};

/// Median, mean and 90th percentile of a set of errors.
struct ErrorStats
{
  std::size_t count = 0;
  double median = 0.0;
  double mean = 0.0;
  double p90 = 0.0;  ///< linear interpolation between closest ranks
  std::vector<double> values;
};

/// Truth speed band of a matched object: static, the moving ones by truth speed over ground
/// (0.5–1, 1–3, > 3 m/s; a moving object slower than 0.5 m/s, possible only with a lower dynamic
/// threshold, falls in the first band), or unknown (truth motion unknown, or a moving object
/// without a velocity).
enum class SpeedBand : std::uint8_t
{
  kStatic = 0,
  kBelow1 = 1,  ///< [0.5, 1) m/s
  k1To3 = 2,    ///< [1, 3) m/s
  kAbove3 = 3,  ///< >= 3 m/s
  kUnknown = 4,
};

/// "static", "0.5-1", "1-3", ">3" or "unknown".
std::string toString(SpeedBand band);

/// The band of a ground-truth object (its motion and, when `has_state`, its speed [m/s]).
SpeedBand speedBandOf(Motion truth_motion, bool has_state, double truth_speed_mps);

/// One ground-truth object matched by class and IoU (whatever the motion): what the per-class
/// and per-speed-band summaries of the motion and the state errors are made of.
struct MatchedObject
{
  std::string frame;
  std::string label;  ///< object class, e.g. "car"
  Motion truth_motion = Motion::kUnknown;
  Motion predicted_motion = Motion::kUnknown;
  SpeedBand band = SpeedBand::kUnknown;
  double truth_speed_mps = 0.0;  ///< |v_gt| [m/s] (0 without a ground-truth state)
  double longitudinal_m = 0.0;   ///< of the ground truth [m]
  bool has_state = false;        ///< both have a state: the errors below are valid, else NaN
  double position_error_m = 0.0;
  double speed_error_mps = 0.0;
  double heading_error_rad = 0.0;  ///< NaN unless both are dynamic (as heading_error_rad below)
  std::int64_t truth_id = -1;      ///< the ground truth's track_id (tracklet, track), −1 when unknown
  std::int64_t track_id = -1;      ///< the detection's track_id (DetectedObject.id), −1 when unknown
  double p_dynamic = -1.0;         ///< the detection's P(dynamic), negative when not given
};

/// Whether the published P(dynamic) is a probability: over the matches with a static or dynamic
/// truth and a P(dynamic), in ten bins of P(dynamic) of width 0.1 (the last one closed), how
/// many matches fall in each and how many of them truly move (a reliability diagram).
struct ProbabilityCalibration
{
  static constexpr std::size_t kBins = 10;
  std::array<std::size_t, kBins> count{};    ///< matches per bin
  std::array<std::size_t, kBins> dynamic{};  ///< ... whose truth is dynamic
  std::array<double, kBins> mean_p{};        ///< mean P(dynamic) of the bin's matches (0 if empty)
  std::size_t total = 0;                     ///< matches counted
  /// Brier score: mean of (P(dynamic) − [truth dynamic])², 0 for a perfect forecast, 0.25 for
  /// always 0.5.
  double brier = 0.0;
  /// Expected calibration error: Σ_bins count / total · |mean_p − dynamic / count|.
  double expected_calibration_error = 0.0;
};

/// The calibration of the P(dynamic) of `matches` (those with a static or dynamic truth and a
/// P(dynamic) in [0, 1]).
ProbabilityCalibration probabilityCalibration(const std::vector<MatchedObject>& matches);

/// Predicted-motion counts of a set of matched objects, indexed by Motion (unknown, static,
/// dynamic).
using MotionCounts = std::array<std::size_t, 3>;

/// Parameters of evaluateTracking().
struct TrackingEvaluationConfig
{
  double iou_threshold = 0.5;  ///< minimum IoU of a match, (0, 1]
  /// Range limit [m], > 0, as EvaluationConfig::max_longitudinal_m.
  double max_longitudinal_m = 30.0;
  /// Two changes of the reported motion of one ground-truth object within this time, while its
  /// truth motion stays the same, are a flicker [s], > 0.
  double flicker_window_s = 2.0;
  /// A ground-truth object at least this fast over ground counts as moving for the time to its
  /// first dynamic verdict (TrackingMetrics::dynamic_latency_s) [m/s], > 0.
  double latency_speed_mps = 1.0;

  /// @throws std::invalid_argument naming the bad field.
  void validate() const;
};

/// The time from a moving object's first match to its first dynamic verdict.
struct DynamicLatency
{
  std::string label;      ///< the ground truth's class
  std::int64_t track_id;  ///< the ground truth's identity
  /// [s] from its first match while moving at latency_speed_mps or more to the first match (that
  /// one included) reported dynamic; negative: never reported dynamic while matched.
  double latency_s = -1.0;
};

/// Multi-object tracking figures: CLEAR MOT (Bernardin and Stiefelhagen, 2008) and identity
/// measures (Ristani et al., 2016), over the non-difficult ground truth in range. Matching per
/// frame: same label and IoU >= the threshold; a ground-truth object keeps the detection id it
/// had in its previous matched frame while that detection still qualifies, the rest are
/// assigned by the Hungarian method on IoU. Detections that match only difficult ground truth
/// or ground truth beyond the range, lie beyond it or in a DontCare region are ignored.
/// Ground-truth identities are the track_id of the ground truth (tracklets, tracking labels).
struct TrackingMetrics
{
  std::size_t ground_truth = 0;     ///< ground-truth object-frames
  std::size_t matches = 0;          ///< matched object-frames (true positives)
  std::size_t false_positives = 0;  ///< detections without a ground truth
  std::size_t misses = 0;           ///< ground-truth object-frames without a detection
  /// A ground-truth object matched to another detection id than at its previous match.
  std::size_t id_switches = 0;
  /// A ground-truth object matched again after frames without a match (its track interrupted).
  std::size_t fragmentations = 0;
  double mota = 0.0;                 ///< 1 − (misses + false positives + id switches) / ground truth
  double id_switches_per_100 = 0.0;  ///< id switches per 100 matched object-frames
  std::size_t truth_tracks = 0;      ///< ground-truth identities with a non-difficult frame in range
  std::size_t mostly_tracked = 0;    ///< matched in >= 80 % of their frames
  std::size_t mostly_lost = 0;       ///< matched in < 20 % of their frames
  /// Identity measures: the one-to-one matching of ground-truth identities to detection ids
  /// with the most co-matched object-frames (IDTP); IDF1 = 2 IDTP / (2 IDTP + IDFP + IDFN).
  std::size_t idtp = 0;
  std::size_t idfp = 0;
  std::size_t idfn = 0;
  double idf1 = 0.0;
  double idp = 0.0;  ///< IDTP / (IDTP + IDFP)
  double idr = 0.0;  ///< IDTP / (IDTP + IDFN)
  /// Motion stability over the matched frames of each ground-truth object whose truth motion
  /// (static or dynamic) is the same in two consecutive matched frames: reported motion changes
  /// between them, and flickers (a change less than flicker_window_s after the previous change
  /// of the same object, the truth motion constant in between).
  std::size_t motion_changes = 0;
  std::size_t motion_flickers = 0;
  std::size_t flickering_tracks = 0;  ///< ground-truth identities with at least one flicker
  /// Per ground-truth object matched while moving at latency_speed_mps or more, in identity
  /// order: the time to its first dynamic verdict.
  std::vector<DynamicLatency> dynamic_latency;
};

/// Statistics of the dynamic latencies of `latencies` whose label is `label` (empty: all):
/// count, median and 90th percentile (ErrorStats; an object never reported dynamic counts as
/// +infinity there), the worst and how many were never reported dynamic.
struct LatencyStats
{
  std::size_t count = 0;
  double median_s = 0.0;
  double p90_s = 0.0;
  double worst_s = 0.0;   ///< +infinity when one was never reported dynamic
  std::size_t never = 0;  ///< never reported dynamic while matched
};
LatencyStats latencyStats(const std::vector<DynamicLatency>& latencies, const std::string& label = "");

/// Everything evaluate() measures.
struct EvaluationResult
{
  std::vector<ClassMetrics> classes;    ///< sorted by name; classes of the ground truth first
  double mean_average_precision = 0.0;  ///< over the classes present in the ground truth
  /// confusion[truth][predicted], indices = Motion values (unknown, static, dynamic), over the
  /// objects matched by class and IoU regardless of motion.
  std::array<std::array<std::size_t, 3>, 3> motion_confusion{};
  ErrorStats position_error_m;   ///< |p_det − p_gt| of matched objects with a state
  ErrorStats speed_error_mps;    ///< ||v_det| − |v_gt|| of matched objects with a state
  ErrorStats heading_error_rad;  ///< wrapped |heading_det − heading_gt|, both dynamic
  /// Every match of motion_confusion, in matching order (classes by name, detections by score).
  std::vector<MatchedObject> matched_objects;
  /// Per class: motion_confusion of that class's matches.
  std::map<std::string, std::array<std::array<std::size_t, 3>, 3>> motion_confusion_by_class;
  /// Per class, then per truth speed band: the predicted-motion counts of the matches.
  std::map<std::string, std::map<SpeedBand, MotionCounts>> motion_by_class_and_band;
  /// The calibration of the matches' P(dynamic) (probabilityCalibration(matched_objects)).
  ProbabilityCalibration p_dynamic_calibration;
  /// evaluateTracking()'s figures when the caller computed them (evaluate() does not).
  std::optional<TrackingMetrics> tracking;
};

/// Whether `object` lies within the range limit: longitudinal_m <= `max_longitudinal_m`.
bool inRange(const EvalObject& object, double max_longitudinal_m);

/// The DontCare regions of each frame.
using DontCareRegions = std::map<std::string, std::vector<BoundingBox>>;

/// Whether `box` lies in a DontCare region of `frame`: intersection / area of `box` >= `overlap`
/// ("+1 pixel" convention), as the KITTI devkit's boxoverlap(det, dontcare, "a").
bool inDontCare(const DontCareRegions& regions, const std::string& frame, const BoundingBox& box,
                double overlap);

/// Whether evaluate() ignores the ground-truth object `truth`: difficult, or beyond the range
/// limit (DontCare regions are no ground truth at all).
bool ignoredTruth(const EvalObject& truth, const EvaluationConfig& config);

/// The evaluation classes whose matching takes the ground-truth object `truth`: its own first;
/// with motion classes, ground truth beyond the range limit and ignored ground truth of unknown
/// motion (a tracklet of one pose, a track too short to fit) also that of every other motion of
/// its object class ("unknownCar", "staticCar", "dynamicCar"): a detection of an object beyond
/// the range, or of one whose motion nobody knows, is ignored whatever motion it reports. (A
/// difficult object of known motion stays in its own class, as in the paper: a detection of it
/// with the other motion is a false positive of its class.)
std::vector<std::string> truthClasses(const EvalObject& truth, const EvaluationConfig& config);

/// What the matching of evaluate() (per evaluation class, Cartucho/mAP rules) makes of one
/// detection. Only true and false positives are counted (in the precision, recall and AP).
enum class DetectionOutcome : std::uint8_t
{
  kTruePositive = 0,
  kFalsePositive = 1,
  kIgnoredDifficult = 2,    ///< its best match (IoU >= threshold) is a difficult ground truth
  kIgnoredBeyondRange = 3,  ///< its best match is a ground truth beyond max_longitudinal_m
  kIgnoredDontCare = 4,     ///< a false positive otherwise, in a DontCare region of its frame
  kLeftOutBeyondRange = 5,  ///< itself beyond max_longitudinal_m and no true positive
};

/// "true_positive", "false_positive", "ignored_difficult", "ignored_beyond_range",
/// "ignored_dont_care" or "left_out_beyond_range".
std::string toString(DetectionOutcome outcome);

/// The outcome of every detection of `detections` (same order) in the matching of evaluate().
/// @throws std::invalid_argument for an invalid config.
std::vector<DetectionOutcome> detectionOutcomes(const std::vector<EvalObject>& ground_truth,
                                                const std::vector<EvalObject>& detections,
                                                const EvaluationConfig& config);

/// Tracking figures of `detections` against `ground_truth` (see TrackingMetrics). Objects
/// without a track_id (−1) count as detections and ground truth each with an identity of its
/// own per frame. The range limit and DontCare regions as in evaluate(): ground truth beyond the
/// limit is ignored like difficult ground truth; a detection that matches no counted ground
/// truth is ignored (neither a false positive nor counted by the identity measures) when it
/// qualifies for an ignored one (same label, IoU >= threshold), lies beyond the limit or lies in
/// a DontCare region.
TrackingMetrics evaluateTracking(const std::vector<EvalObject>& ground_truth,
                                 const std::vector<EvalObject>& detections,
                                 const TrackingEvaluationConfig& config);

/// Class name of an object: "dynamicCar" for (kDynamic, "car") when `with_motion`, else "car".
std::string evaluationClass(const std::string& label, Motion motion, bool with_motion);

/// IoU of two boxes with the "+1 pixel" convention (inclusive pixel bounds). 0 when disjoint.
double boxIou(const BoundingBox& a, const BoundingBox& b);

/// VOC2012 all-point interpolated AP of a precision/recall curve (same length, in detection
/// order). 0 for an empty curve.
double vocAveragePrecision(const std::vector<double>& recall, const std::vector<double>& precision);

/// Statistics of `values` (copied); all zero for an empty set.
ErrorStats errorStats(std::vector<double> values);

/// Evaluates `detections` against `ground_truth` (see the file comment for the rules).
EvaluationResult evaluate(const std::vector<EvalObject>& ground_truth,
                          const std::vector<EvalObject>& detections, const EvaluationConfig& config);

}  // namespace grid_vision_fusion
