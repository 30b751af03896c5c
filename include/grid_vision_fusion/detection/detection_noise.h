// The noise of a real detector, drawn on top of the replay backend's oracle boxes: misses and
// score spread, box-edge jitter, partial boxes of occluded objects, class confusion, extra boxes
// on found objects and false positives on the background. Its default magnitudes are those
// measured for YOLOv5s at 640x192 on real KITTI frames by scripts/calibrate_detector_noise.py;
// doc/detector_noise.md describes the model, the calibration and what it does to the fusion.
//
// Every draw comes from a stream seeded by (seed, frame index, component, label index): the same
// frame index gives the same detections whatever was replayed before (the nodelet, which may
// drop images, and run_pipeline agree), and switching one component off leaves the draws of the
// others unchanged.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "grid_vision_fusion/types.h"

namespace grid_vision_fusion
{
/// The labels the noise model knows (the detector's class_map: COCO car, bus -> van, truck,
/// person -> pedestrian, bicycle -> cyclist), in the order of their offsets.
const std::vector<std::string>& noiseModelLabels();

/// Weights of a linear predictor over a label's covariates: an offset per label (the value at
/// a box height of kNoiseReferenceHeight px, unoccluded, untruncated), + height_slope * ln(h /
/// kNoiseReferenceHeight) + occlusion1 or occlusion2 (KITTI occlusion level 1, 2) + truncation *
/// (the label's truncated fraction).
struct NoiseCovariateWeights
{
  double car = 0.0;
  double van = 0.0;
  double truck = 0.0;
  double pedestrian = 0.0;
  double cyclist = 0.0;
  double height_slope = 0.0;
  double occlusion1 = 0.0;
  double occlusion2 = 0.0;
  double truncation = 0.0;

  /// The predictor of a label of noiseModelLabels() index `label` (0..4).
  double predictor(std::size_t label, double box_height, int occlusion, double truncated) const;
};

/// Box height [px] at which the offsets of NoiseCovariateWeights apply.
constexpr double kNoiseReferenceHeight = 50.0;

/// The error of one box edge [px] (+: right / down): bias * h + a deviation N(0, sigma_px^2 +
/// (sigma_fraction * h)^2), scaled by tail_scale with probability tail_probability (the wider
/// of two Gaussians: real edge errors have heavy tails); h is the label's box height [px].
struct BoxEdgeNoise
{
  double bias = 0.0;              ///< [fraction of h], any finite value
  double sigma_px = 0.0;          ///< [px] >= 0
  double sigma_fraction = 0.0;    ///< [fraction of h] >= 0
  double tail_probability = 0.0;  ///< [0, 1]
  double tail_scale = 1.0;        ///< >= 0
};

/// False positives away from every object ("background"), per image.
struct FalsePositiveNoise
{
  double rate = 0.0;        ///< mean count per image with a score >= min_score (Poisson), [0, 100]
  double score_mean = 0.0;  ///< their logit(score / score_max) ~ N(score_mean, score_sigma^2) above min_score
  double score_sigma = 1.0;     ///< > 0
  double height_median = 26.0;  ///< [px] > 0: box height log-normal
  double height_sigma = 0.7;    ///< sigma of ln(height) >= 0
  double bottom_min = 0.46;     ///< box bottom uniform in [bottom_min, bottom_max] x image height, [0, 1]
  double bottom_max = 0.80;
  double vehicle_aspect = 1.6;  ///< width / height of a car, van or truck box, > 0
  double person_aspect = 0.7;   ///< width / height of a pedestrian or cyclist box, > 0
  /// Relative frequency of each label, >= 0 (normalised; their sum > 0 when rate > 0).
  double car = 0.0;
  double van = 0.0;
  double truck = 0.0;
  double pedestrian = 0.0;
  double cyclist = 0.0;
};

/// The noise model. Defaults: the calibration of YOLOv5s 640x192 (doc/detector_noise.md), off.
struct DetectionNoiseConfig
{
  bool enabled = false;    ///< false: the oracle boxes, unchanged
  std::uint32_t seed = 0;  ///< the noise of (seed, frame index) is always the same
  // The components, each on its own (all need `enabled`); keys replay/noise/components/...
  bool misses = true;           ///< presence and score of each label's box (else the label's score)
  bool box_jitter = true;       ///< edge errors
  bool partial_boxes = true;    ///< occluded objects boxed by their visible part
  bool confusion = true;        ///< car / van / truck and pedestrian / cyclist confusion
  bool extra_boxes = true;      ///< a second box on a found object
  bool false_positives = true;  ///< boxes on the background

  /// Scores below this are never produced (the calibration's floor), (0, score_max).
  double min_score = 0.05;
  /// Scores are score_max * sigmoid(z) (YOLOv5s's scores stay below ~0.93), (0, 1].
  double score_max = 0.95;
  /// A label with KITTI occlusion 3 (the synthetic drives: no pixel visible) is never detected
  /// (false), or is taken as occlusion 2 (true).
  bool fully_occluded_detected = false;
  /// Labels other than noiseModelLabels() (tram, misc, ...): dropped by `misses`, as the
  /// detector's class_map drops them (false), or kept with the other components (true).
  bool keep_other_labels = false;

  /// P(a box with a score >= min_score) = sigmoid(presence predictor).
  NoiseCovariateWeights presence{4.475, 3.195, 3.128, 1.420, 0.918, 2.023, -1.639, -2.655, -3.159};
  /// The box's logit(score / score_max) ~ N(score predictor, score_sigma^2), above min_score.
  NoiseCovariateWeights score{1.719, 0.528, 0.514, 0.117, 0.077, 1.562, -0.627, -1.115, -1.864};
  double score_sigma = 0.844;  ///< > 0

  BoxEdgeNoise left{0.021, 2.818, 0.037, 0.182, 5.046};
  BoxEdgeNoise top{0.022, 0.0, 0.031, 0.349, 3.390};
  BoxEdgeNoise right{-0.041, 1.339, 0.042, 0.200, 5.878};
  BoxEdgeNoise bottom{-0.032, 0.0, 0.035, 0.478, 2.628};
  /// The edge deviations (not the biases) of a pedestrian's or cyclist's box are multiplied by
  /// this (narrow boxes: smaller errors relative to their height than a vehicle's), >= 0.
  double person_scale = 0.626;

  /// P(the box is a partial one) by the label's occlusion level 0, 1, 2 (3 taken as 2), [0, 1].
  double partial_occlusion0 = 0.021;
  double partial_occlusion1 = 0.104;
  double partial_occlusion2 = 0.250;
  /// A partial box keeps a width uniform in [width_min, width_max] of the label's, on its left
  /// or right side (even odds); 0 < width_min <= width_max <= 1.
  double partial_width_min = 0.455;
  double partial_width_max = 0.764;

  /// P(the label published is another one), [0, 1]; the two of a row sum to <= 1.
  double car_to_van = 0.0;
  double car_to_truck = 0.0;
  double van_to_car = 0.765;
  double van_to_truck = 0.176;
  double truck_to_car = 0.0;
  double truck_to_van = 0.111;
  double pedestrian_to_cyclist = 0.033;
  double cyclist_to_pedestrian = 0.818;

  /// Mean count (Poisson) of extra boxes on a found object with a score >= min_score, [0, 100]:
  /// a partial box of it with its own edge errors (also when box_jitter is off), its label drawn
  /// through the confusion again, its score from the false positives' score model.
  double extra_rate = 0.850;

  FalsePositiveNoise background{4.379, -4.267, 1.873, 25.785, 0.681, 0.464, 0.802,
                                1.577, 0.706,  0.567, 0.009,  0.024, 0.248, 0.152};

  /// @throws std::invalid_argument naming the first bad parameter (replay/noise/...).
  void validate() const;
};

/// One label as the noise sees it: its oracle detection (label after the class_map, clipped box,
/// score) and what the label file says of its visibility.
struct NoiseLabel
{
  Detection detection;
  float truncated = 0.F;  ///< [0, 1]
  int occluded = 0;       ///< KITTI level 0..3
  std::size_t line = 0;   ///< its index among the labels of its file: the index of its noise streams
};

/// The detections of one frame under the noise: every label's box (or none), extra boxes and
/// false positives, in order of decreasing score (stable). Scores are not thresholded here.
/// `image_width`/`image_height` 0: no border handling and no false positives.
std::vector<Detection> applyDetectionNoise(const DetectionNoiseConfig& config, std::int64_t frame_index,
                                           const std::vector<NoiseLabel>& labels, std::uint32_t image_width,
                                           std::uint32_t image_height);

/// The published label's class_id: its KITTI type's index in kittiObjectTypes() (car 0, van 1,
/// truck 2, pedestrian 3, cyclist 5).
std::uint32_t noiseClassId(const std::string& label);

}  // namespace grid_vision_fusion
