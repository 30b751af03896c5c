// The parameter tables of the four nodes: for each, every parameter name of its private
// namespace (and of its config/*.yaml file) with the field it fills. A default is written once,
// in the field's struct: the YAML files and the dynamic_reconfigure .cfg files are checked
// against these tables by test/ros/test_node_params.cpp.
//
// A table is visited (visitParams) by a ParamReader to read it, by ParamValues to list its
// values; fromParams() reads, validates and reports the unknown names of a source.
#pragma once

#include <string>
#include <vector>

#include "grid_vision_fusion/detection/detection_replay.h"
#include "grid_vision_fusion/detection/yolo_detector.h"
#include "grid_vision_fusion/fusion/fusion.h"
#include "grid_vision_fusion/fusion/tracker.h"
#include "grid_vision_fusion/grid/dynamic_grid_filter.h"
#include "grid_vision_fusion/projection/grid_projection.h"
#include "grid_vision_fusion/ros/params.h"

namespace grid_vision_fusion
{
// --- enumerations: read from and written as their names ----------------------------------------
bool paramValueAs(const XmlRpc::XmlRpcValue& value, TieRule& out);
bool paramValueAs(const XmlRpc::XmlRpcValue& value, PositionSource& out);
bool paramValueAs(const XmlRpc::XmlRpcValue& value, MotionVote& out);
bool paramValueAs(const XmlRpc::XmlRpcValue& value, ResizeMode& out);
bool paramValueAs(const XmlRpc::XmlRpcValue& value, YoloOutputLayout& out);
bool paramValueAs(const XmlRpc::XmlRpcValue& value, FrameIndexSource& out);
XmlRpc::XmlRpcValue toParamValue(TieRule value);
XmlRpc::XmlRpcValue toParamValue(PositionSource value);
XmlRpc::XmlRpcValue toParamValue(MotionVote value);
XmlRpc::XmlRpcValue toParamValue(ResizeMode value);
XmlRpc::XmlRpcValue toParamValue(YoloOutputLayout value);
XmlRpc::XmlRpcValue toParamValue(FrameIndexSource value);

// --- class footprints: a map from label to [length, width] [m] ----------------------------------
bool paramValueAs(const XmlRpc::XmlRpcValue& value, std::map<std::string, Footprint>& out);
XmlRpc::XmlRpcValue toParamValue(const std::map<std::string, Footprint>& value);

// --- dynamic_grid ------------------------------------------------------------------------------

/// The dynamic_grid node's parameters (config/dynamic_grid.yaml): its own options and the
/// filter's DynamicGridConfig (sensor model keys flat, without prefix).
struct DynamicGridParams
{
  std::string fixed_frame =
      "odom";                   ///< frame of the grid and of the filter's poses (REP 105 odom), non-empty
  bool lazy = true;             ///< subscribe only while someone listens
  int queue_size = 5;           ///< clouds waiting for their tf (>= 1)
  double expected_rate = 10.0;  ///< scan rate for the diagnostics [Hz] (> 0)
  DynamicGridConfig filter;

  /// Reads, validates; `unknown` (when given) receives a warning per unknown parameter name.
  /// @throws std::invalid_argument naming the parameter at fault.
  static DynamicGridParams fromParams(const ParamSource& source, std::vector<std::string>* unknown = nullptr);
};

template <typename Visitor>
void visitParams(DynamicGridParams& p, Visitor& v)
{
  v("fixed_frame", p.fixed_frame);
  v("lazy", p.lazy);
  v("queue_size", p.queue_size);
  v("expected_rate", p.expected_rate);
  v.foreign("diagnostic_period");
  auto& c = p.filter;
  v("width", c.width);
  v("height", c.height);
  v("resolution", c.resolution);
  v("lookahead", c.lookahead);
  v("max_time_gap", c.max_time_gap);
  v("transition_period", c.transition_period);
  v("eps_static_to_dynamic", c.eps_static_to_dynamic);
  v("eps_static_to_unknown", c.eps_static_to_unknown);
  v("eps_dynamic_to_static", c.eps_dynamic_to_static);
  v("eps_dynamic_to_unknown", c.eps_dynamic_to_unknown);
  v("eps_free_to_static", c.eps_free_to_static);
  v("eps_free_to_dynamic", c.eps_free_to_dynamic);
  v("eps_free_to_unknown", c.eps_free_to_unknown);
  v("eps_unknown_to_static", c.eps_unknown_to_static);
  v("eps_unknown_to_dynamic", c.eps_unknown_to_dynamic);
  v("eps_unknown_to_free", c.eps_unknown_to_free);
  v("particle_count", c.particle_count);
  v("birth_fraction", c.birth_fraction);
  v("birth_velocity_sigma", c.birth_velocity_sigma);
  v("birth_motion_speed", c.birth_motion_speed);
  v("birth_motion_fraction", c.birth_motion_fraction);
  v("acceleration_sigma", c.acceleration_sigma);
  v("max_speed", c.max_speed);
  v("vacated_to_dynamic", c.vacated_to_dynamic);
  v("motion_window", c.motion_window);
  v("motion_radius", c.motion_radius);
  v("motion_memory", c.motion_memory);
  v("unknown_to_dynamic_by_motion", c.unknown_to_dynamic_by_motion);
  v("static_to_dynamic_by_motion", c.static_to_dynamic_by_motion);
  v("inherit_birth_velocity", c.inherit_birth_velocity);
  v("propagation_rate", c.propagation_rate);
  v("propagation_length", c.propagation_length);
  v("seed", c.seed);
  v("threads", c.threads);
  v("dynamic_threshold", c.dynamic_threshold);
  v("min_dynamic_speed", c.min_dynamic_speed);
  v("mahalanobis_threshold", c.mahalanobis_threshold);
  v("occupied_threshold", c.occupied_threshold);
  auto& m = c.sensor_model;
  v("sensor_height", m.sensor_height);
  v("min_range", m.min_range);
  v("max_range", m.max_range);
  v("angular_resolution", m.angular_resolution);
  v("range_resolution", m.range_resolution);
  v("max_ground_slope", m.max_ground_slope);
  v("ground_tolerance", m.ground_tolerance);
  v("min_obstacle_height", m.min_obstacle_height);
  v("max_obstacle_height", m.max_obstacle_height);
  v("p_occupied", m.p_occupied);
  v("p_free", m.p_free);
  v("range_sigma", m.range_sigma);
  v("hit_neighbours_not_free", m.hit_neighbours_not_free);
}

// --- yolo_detector -----------------------------------------------------------------------------

/// The yolo_detector node's parameters (config/yolo_detector.yaml): the backend and the
/// configuration of each. score_threshold is one parameter for both backends.
struct DetectorParams
{
  std::string backend = "opencv_dnn";  ///< "opencv_dnn" (a YOLO network) or "replay" (label files)
  bool lazy = true;
  YoloDetectorConfig yolo;       ///< used with opencv_dnn (keys without prefix)
  DetectionReplayConfig replay;  ///< used with replay (keys replay/...)

  /// Reads and validates the configuration of the chosen backend; `unknown` as above.
  /// @throws std::invalid_argument naming the parameter at fault.
  static DetectorParams fromParams(const ParamSource& source, std::vector<std::string>* unknown = nullptr);
};

/// The replay backend's noise model (keys replay/noise/..., detection_noise.h).
template <typename Visitor>
void visitReplayNoiseParams(DetectionNoiseConfig& n, Visitor& v)
{
  const std::string k = "replay/noise/";
  v(k + "enabled", n.enabled);
  v(k + "seed", n.seed);
  v(k + "components/misses", n.misses);
  v(k + "components/box_jitter", n.box_jitter);
  v(k + "components/partial_boxes", n.partial_boxes);
  v(k + "components/confusion", n.confusion);
  v(k + "components/extra_boxes", n.extra_boxes);
  v(k + "components/false_positives", n.false_positives);
  v(k + "min_score", n.min_score);
  v(k + "score_max", n.score_max);
  v(k + "fully_occluded_detected", n.fully_occluded_detected);
  v(k + "keep_other_labels", n.keep_other_labels);
  const auto weights = [&](const std::string& prefix, NoiseCovariateWeights& w)
  {
    v(prefix + "car", w.car);
    v(prefix + "van", w.van);
    v(prefix + "truck", w.truck);
    v(prefix + "pedestrian", w.pedestrian);
    v(prefix + "cyclist", w.cyclist);
    v(prefix + "height_slope", w.height_slope);
    v(prefix + "occlusion1", w.occlusion1);
    v(prefix + "occlusion2", w.occlusion2);
    v(prefix + "truncation", w.truncation);
  };
  weights(k + "presence/", n.presence);
  weights(k + "score/", n.score);
  v(k + "score/sigma", n.score_sigma);
  const auto edge = [&](const std::string& name, BoxEdgeNoise& e)
  {
    v(k + "box/" + name + "/bias", e.bias);
    v(k + "box/" + name + "/sigma_px", e.sigma_px);
    v(k + "box/" + name + "/sigma_fraction", e.sigma_fraction);
    v(k + "box/" + name + "/tail_probability", e.tail_probability);
    v(k + "box/" + name + "/tail_scale", e.tail_scale);
  };
  edge("left", n.left);
  edge("top", n.top);
  edge("right", n.right);
  edge("bottom", n.bottom);
  v(k + "box/person_scale", n.person_scale);
  v(k + "partial/occlusion0", n.partial_occlusion0);
  v(k + "partial/occlusion1", n.partial_occlusion1);
  v(k + "partial/occlusion2", n.partial_occlusion2);
  v(k + "partial/width_min", n.partial_width_min);
  v(k + "partial/width_max", n.partial_width_max);
  v(k + "confusion/car_to_van", n.car_to_van);
  v(k + "confusion/car_to_truck", n.car_to_truck);
  v(k + "confusion/van_to_car", n.van_to_car);
  v(k + "confusion/van_to_truck", n.van_to_truck);
  v(k + "confusion/truck_to_car", n.truck_to_car);
  v(k + "confusion/truck_to_van", n.truck_to_van);
  v(k + "confusion/pedestrian_to_cyclist", n.pedestrian_to_cyclist);
  v(k + "confusion/cyclist_to_pedestrian", n.cyclist_to_pedestrian);
  v(k + "extra_rate", n.extra_rate);
  auto& f = n.background;
  v(k + "false_positives/rate", f.rate);
  v(k + "false_positives/score_mean", f.score_mean);
  v(k + "false_positives/score_sigma", f.score_sigma);
  v(k + "false_positives/height_median", f.height_median);
  v(k + "false_positives/height_sigma", f.height_sigma);
  v(k + "false_positives/bottom_min", f.bottom_min);
  v(k + "false_positives/bottom_max", f.bottom_max);
  v(k + "false_positives/vehicle_aspect", f.vehicle_aspect);
  v(k + "false_positives/person_aspect", f.person_aspect);
  v(k + "false_positives/car", f.car);
  v(k + "false_positives/van", f.van);
  v(k + "false_positives/truck", f.truck);
  v(k + "false_positives/pedestrian", f.pedestrian);
  v(k + "false_positives/cyclist", f.cyclist);
}

template <typename Visitor>
void visitParams(DetectorParams& p, Visitor& v)
{
  v("backend", p.backend);
  v("lazy", p.lazy);
  v.foreign("image_transport");
  v.foreign("diagnostic_period");
  v("score_threshold", p.yolo.score_threshold);  // both backends: copied to replay by fromParams()
  v("nms_threshold", p.yolo.nms_threshold);
  v("model", p.yolo.model_path);
  v("weights", p.yolo.weights_path);
  v("class_names", p.yolo.class_names_path);
  v("input_width", p.yolo.input_width);
  v("input_height", p.yolo.input_height);
  v("resize_mode", p.yolo.resize_mode);
  v("network_rgb", p.yolo.network_rgb);
  v("onnx_layout", p.yolo.onnx_layout);
  v("dnn_backend", p.yolo.backend);
  v("dnn_target", p.yolo.target);
  v("class_map", p.yolo.class_map);
  v("rider_merge", p.yolo.rider_merge);
  v("rider_class", p.yolo.rider_class);
  v("replay/directory", p.replay.directory);
  v("replay/file_pattern", p.replay.file_pattern);
  v("replay/frame_index", p.replay.index_source);
  v("replay/first_index", p.replay.first_index);
  v("replay/class_map", p.replay.class_map);
  v("replay/default_score", p.replay.default_score);
  v("replay/missing_file_is_empty", p.replay.missing_file_is_empty);
  visitReplayNoiseParams(p.replay.noise, v);
}

// --- grid_projection ---------------------------------------------------------------------------

/// The grid_projection node's parameters (config/grid_projection.yaml).
struct GridProjectionParams
{
  /// Frame whose origin the ground plane is ground_height below (empty: ground_height is the z
  /// of the ground in the grid frame itself).
  std::string ground_frame = "velo_link";
  double ground_height = -1.73;  ///< [m], finite
  double max_grid_age = 0.5;     ///< largest |t_image − t_grid| projected [s] (> 0)
  /// A camera_info waits for a grid stamped at most this before it (its own sweep's) [s],
  /// finite; < 0: never waits, the newest grid at once (GridForImage).
  double grid_sync_tolerance = 0.05;
  int image_cache_size = 5;  ///< images kept for the overlay (>= 1)
  int queue_size = 5;        ///< camera_infos waiting for their tf (>= 1)
  bool lazy = true;
  GridProjectionConfig projection;

  /// @throws std::invalid_argument naming the parameter at fault.
  static GridProjectionParams fromParams(const ParamSource& source,
                                         std::vector<std::string>* unknown = nullptr);
};

template <typename Visitor>
void visitParams(GridProjectionParams& p, Visitor& v)
{
  v("ground_frame", p.ground_frame);
  v("ground_height", p.ground_height);
  v("ground_from_grid", p.projection.ground_from_grid);
  v("max_grid_age", p.max_grid_age);
  v("grid_sync_tolerance", p.grid_sync_tolerance);
  v("image_cache_size", p.image_cache_size);
  v("queue_size", p.queue_size);
  v("lazy", p.lazy);
  v.foreign("image_transport");
  v("occupied_threshold", p.projection.occupied_threshold);
  v("dynamic_ratio", p.projection.dynamic_ratio);
  v("min_dynamic_speed", p.projection.min_dynamic_speed);
  v("mahalanobis_threshold", p.projection.mahalanobis_threshold);
  v("min_depth", p.projection.min_depth);
  v("column_mode", p.projection.column_mode);
  v("column_height", p.projection.column_height);
  v("column_points", p.projection.column_points);
  v("near_cells_at_bottom", p.projection.near_cells_at_bottom);
  v("predict_to_image_stamp", p.projection.predict_to_image_stamp);
}

// --- fusion ------------------------------------------------------------------------------------

/// The fusion node's parameters (config/fusion.yaml).
struct FusionParams
{
  bool lazy = true;
  bool approximate_sync = false;  ///< approximate instead of exact stamp matching
  int queue_size = 10;            ///< synchroniser queue per input (>= 1)
  int image_cache_size = 10;      ///< images kept for the overlay (>= 1)
  FusionConfig fusion;
  /// Track the objects from image to image (ids, filtered state, motion over time); false: the
  /// paper's per-frame output (ids = index in the array).
  bool tracking = true;
  TrackerConfig tracker;

  /// @throws std::invalid_argument naming the parameter at fault.
  static FusionParams fromParams(const ParamSource& source, std::vector<std::string>* unknown = nullptr);

  /// A warning for each option of the paper's per-frame verdict (~min_points, ~tie_rule) set away
  /// from its default while ~tracking is on: the track's motion model decides then, and the option
  /// changes nothing.
  std::vector<std::string> perFrameOptionsIgnored() const;
};

template <typename Visitor>
void visitParams(FusionParams& p, Visitor& v)
{
  v("lazy", p.lazy);
  v("approximate_sync", p.approximate_sync);
  v("queue_size", p.queue_size);
  v("image_cache_size", p.image_cache_size);
  v.foreign("image_transport");
  v("band_above", p.fusion.band_above);
  v("band_below", p.fusion.band_below);
  v("min_points", p.fusion.min_points);
  v("tie_rule", p.fusion.tie_rule);
  v("exclusive_assignment", p.fusion.exclusive_assignment);
  v("motion_vote", p.fusion.motion_vote);
  v("position", p.fusion.position);
  v("centre_cluster_distance", p.fusion.centre.cluster_distance);
  v("centre_max_scans_since_hit", p.fusion.centre.max_scans_since_hit);
  v("class_footprints", p.fusion.centre.footprints);
  v("tracking", p.tracking);
  auto& t = p.tracker;
  v("track_min_hits", t.min_hits);
  v("track_max_misses", t.max_misses);
  v("track_gate_sigma", t.gate_sigma);
  v("track_min_iou", t.min_iou);
  v("track_iou_weight", t.iou_weight);
  v("track_position_sigma", t.position_sigma);
  v("track_max_gap", t.max_gap);
  v("track_box_gain", t.box_gain);
  v("track_label_groups", t.label_groups);
  v("track_acceleration_sigma", t.motion.acceleration_sigma);
  v("motion_position_sigma", t.motion.position_sigma);
  v("motion_speed_sigma", t.motion.speed_sigma);
  v("motion_class_speed_sigmas", t.class_speed_sigmas);
  v("motion_switch_time", t.motion.switch_time);
  v("motion_grid_error", t.motion.grid_error);
}

/// The values of the table `params` by parameter name (the defaults for a default-constructed one).
template <typename Params>
std::map<std::string, XmlRpc::XmlRpcValue> paramValuesOf(Params params)
{
  ParamValues values;
  visitParams(params, values);
  return values.values;
}

}  // namespace grid_vision_fusion
