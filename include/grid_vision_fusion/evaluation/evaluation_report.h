// Outputs of the evaluation: metrics.json, report.md (tables like the paper's Tables I and II),
// Cartucho/mAP input folders, PR curves and error histograms as PNG (drawn with OpenCV).
#pragma once

#include <opencv2/core.hpp>

#include <string>
#include <vector>

#include "grid_vision_fusion/evaluation/evaluation.h"

namespace grid_vision_fusion
{
/// The result as JSON: per class figures and curves, mAP, confusion matrix, per object class the
/// confusion matrix and the predicted-motion counts per truth speed band ("motion_by_class"),
/// error statistics, the P(dynamic) calibration and, with tracking figures, "tracking". Written
/// by nlohmann/json, indented by 2, the keys in this order; every figure rounded to 6 decimals
/// as before (the calibration bins' limits to 1), null where it is not finite.
std::string metricsJson(const EvaluationResult& result, const EvaluationConfig& config);

/// Every matched object of the motion confusion as CSV, one line each after the header
/// frame,label,truth_motion,predicted_motion,truth_band,truth_speed_mps,longitudinal_m,
/// position_error_m,speed_error_mps,heading_error_rad (motions unknown/static/dynamic; bands as
/// toString(SpeedBand); errors empty where the match has none): for summaries over several runs.
std::string matchesCsv(const EvaluationResult& result);

/// A Markdown report: Table I (precision, recall, F1 per class, in percent), Table II (AP per
/// class and mAP), the motion confusion matrix and the error statistics.
std::string reportMarkdown(const EvaluationResult& result, const EvaluationConfig& config);

/// Writes the Cartucho/mAP inputs under `dir`: ground-truth/<frame>.txt with lines
/// "<class> <left> <top> <right> <bottom>[ difficult]" and detection-results/<frame>.txt with
/// "<class> <score> <left> <top> <right> <bottom>", one file per frame of either list (empty when
/// the frame has no object), classes named as evaluate() names them. Every ground-truth object
/// is written, in each class of truthClasses() and marked difficult when evaluate() ignores it
/// (difficult, beyond the range limit; DontCare regions are not written); of the detections only
/// those evaluate() counts, its true and false
/// positives (detectionOutcomes()): Cartucho/mAP then takes the same decision for each of them
/// and gives the same AP per class and mAP. (It cannot see DontCare regions or a detection's
/// range, and it divides by zero when the first detection of a class is ignored.)
/// @throws std::runtime_error naming a file that cannot be written.
void writeCartuchoFolders(const std::string& dir, const std::vector<EvalObject>& ground_truth,
                          const std::vector<EvalObject>& detections, const EvaluationConfig& config);

/// A precision/recall plot of one class (recall on x, precision on y, both [0, 1]), titled
/// with its AP. 640 x 480, CV_8UC3.
cv::Mat drawPrCurve(const ClassMetrics& metrics);

/// A histogram of `values` with `bins` equal bins from 0 to the largest value, titled `title`,
/// x axis labelled `unit`, with the median and the 90th percentile marked. 640 x 480, CV_8UC3.
cv::Mat drawHistogram(const ErrorStats& stats, const std::string& title, const std::string& unit,
                      int bins = 20);

/// Writes metrics.json, report.md, matches.csv, the Cartucho folders, pr_<class>.png for every
/// class and hist_position.png, hist_speed.png, hist_heading.png into `dir` (created if needed).
/// @throws std::runtime_error naming a file that cannot be written.
void writeEvaluationOutputs(const std::string& dir, const EvaluationResult& result,
                            const EvaluationConfig& config, const std::vector<EvalObject>& ground_truth,
                            const std::vector<EvalObject>& detections);

}  // namespace grid_vision_fusion
