// The four stages (dynamic grid, detector, grid projection, fusion) off line: fed with the
// messages of a bag in time order, without roscore, through the very stage classes the nodelets
// use, deterministically. The Pipeline only schedules; run_pipeline is a thin tool around it.
#pragma once

#include <rosbag/bag.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>
#include <sensor_msgs/PointCloud2.h>
#include <tf2/buffer_core.h>
#include <tf2_msgs/TFMessage.h>

#include <cstddef>
#include <deque>
#include <functional>
#include <future>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "grid_vision_fusion/DetectedObjectArray.h"
#include "grid_vision_fusion/Detection2DArray.h"
#include "grid_vision_fusion/DynamicGrid.h"
#include "grid_vision_fusion/ProjectedGrid.h"
#include "grid_vision_fusion/ros/node_params.h"
#include "grid_vision_fusion/ros_stages/detector_stage.h"
#include "grid_vision_fusion/ros_stages/fusion_stage.h"
#include "grid_vision_fusion/ros_stages/grid_stage.h"
#include "grid_vision_fusion/ros_stages/projection_stage.h"

namespace grid_vision_fusion
{
/// Everything the four stages are configured with: the parameters of the four nodelets
/// (config/dynamic_grid.yaml, yolo_detector.yaml, grid_projection.yaml, fusion.yaml).
struct PipelineConfig
{
  DynamicGridParams grid;
  DetectorParams detector;
  GridProjectionParams projection;
  FusionParams fusion;  ///< its queue_size is the queue of detections / projected grids waiting for a partner
  /// How long (bag time) a sensor message may wait for the tf it needs before it is handled
  /// anyway (and dropped by its stage if tf still cannot answer) [s], >= 0. The nodelets wait
  /// for tf too (through tf message filters).
  double max_tf_wait = 0.5;
  /// Run the detector of image k on a worker thread while the other stages go on with the
  /// messages after it (the grid of scan k+1...). The detections are collected at fixed points
  /// of the message sequence (before the next image, at finish()), so the output is the same,
  /// bit for bit, as without overlap.
  bool overlap_detector = true;
};

/// The PipelineConfig of the four parameter sources, read as the nodelets read them.
/// `unknown` (when given) receives a warning per parameter name no node knows.
/// @throws std::invalid_argument naming the parameter at fault.
PipelineConfig pipelineConfigFromParams(const ParamSource& grid, const ParamSource& detector,
                                        const ParamSource& projection, const ParamSource& fusion,
                                        std::vector<std::string>* unknown = nullptr);

/// Per-stage wall times [ms] of every processed message and counters.
struct PipelineStats
{
  std::vector<double> grid_ms;        ///< per cloud
  std::vector<double> detector_ms;    ///< per image
  std::vector<double> projection_ms;  ///< per camera_info
  std::vector<double> fusion_ms;      ///< per fused pair
  std::size_t clouds = 0, images = 0, camera_infos = 0;
  std::size_t grids = 0, detections = 0, projections = 0, objects = 0;
  std::size_t grid_drops = 0;                 ///< clouds without tf / with unusable fields
  std::size_t detector_drops = 0;             ///< images that could not be processed
  std::size_t projection_drops = 0;           ///< camera_infos without grid / tf / usable camera
  std::size_t projections_without_cells = 0;  ///< of `projections`: the grid too old for the image
  std::size_t fusion_drops = 0;               ///< pairs refused, or an output without partner
  std::size_t grid_resets = 0;
  std::vector<std::string> warnings;  ///< first few distinct reasons: drops, projections without cells
};

/// Where the outputs go; each may be empty.
struct PipelineOutputs
{
  std::function<void(const DetectedObjectArray::ConstPtr&)> objects;
  std::function<void(const DynamicGrid::ConstPtr&)> grid;  ///< only when set: the grid messages are built
  std::function<void(const ProjectedGrid::ConstPtr&)> projected_grid;
  std::function<void(const Detection2DArray::ConstPtr&)> detections;
};

/// The four stages. Feed the messages in bag order (add*()); a sensor message is processed when
/// the messages read so far say all earlier ones are in, and tf can answer for it (or it has
/// waited max_tf_wait); call finish() at the end. Order of processing: by header stamp, and at
/// equal stamps clouds first, then images, then camera_infos, so that a camera_info is
/// projected with the grid of the latest scan at or before its stamp. Not thread-safe.
class Pipeline
{
public:
  /// @throws std::invalid_argument for an invalid configuration; what the detector throws while
  /// loading its model.
  Pipeline(const PipelineConfig& config, PipelineOutputs outputs);
  ~Pipeline();

  /// /tf (is_static false) or /tf_static messages.
  void addTf(const tf2_msgs::TFMessage& msg, bool is_static);
  void addCloud(const sensor_msgs::PointCloud2::ConstPtr& msg);
  void addImage(const sensor_msgs::Image::ConstPtr& msg);
  void addCameraInfo(const sensor_msgs::CameraInfo::ConstPtr& msg);
  /// The bag time of the message just read (non-decreasing): releases what may be processed.
  void advanceTo(const ros::Time& bag_time);
  /// Processes every waiting message.
  void finish();

  const PipelineStats& stats() const { return stats_; }
  const PipelineConfig& config() const { return config_; }
  /// Warnings of the detector while loading (backend fallbacks).
  std::vector<std::string> detectorWarnings() const { return detector_->detector().warnings(); }

private:
  enum class Kind
  {
    kCloud = 0,
    kImage = 1,
    kCameraInfo = 2
  };
  struct Pending
  {
    ros::Time stamp;
    Kind kind;
    std::uint64_t order;  ///< arrival order, the last tie breaker
    sensor_msgs::PointCloud2::ConstPtr cloud;
    sensor_msgs::Image::ConstPtr image;
    sensor_msgs::CameraInfo::ConstPtr info;
  };

  void enqueue(Pending pending);
  void release(bool everything);
  bool tfReady(const Pending& pending) const;
  void process(const Pending& pending);
  void processCloud(const sensor_msgs::PointCloud2& msg);
  void processImage(const sensor_msgs::Image::ConstPtr& msg);
  /// Waits for the detection in flight (if any) and hands its result on as processImage() did.
  void collectDetection();
  void processCameraInfo(const sensor_msgs::CameraInfo& msg);
  void tryFuse(const ros::Time& stamp);
  void warn(const std::string& what);

  PipelineConfig config_;
  PipelineOutputs outputs_;
  PipelineStats stats_;
  tf2::BufferCore tf_;
  std::unique_ptr<GridStage> grid_;
  std::unique_ptr<DetectorStage> detector_;
  std::unique_ptr<ProjectionStage> projection_;
  std::unique_ptr<FusionStage> fusion_;
  DynamicGrid::ConstPtr latest_grid_;
  /// The image whose detection runs on the worker, and its result with the detector's time [ms].
  sensor_msgs::Image::ConstPtr detecting_;
  std::future<std::pair<std::vector<Detection>, double>> detection_;
  std::deque<Pending> queue_;  ///< sorted by (stamp, kind, order)
  std::uint64_t arrivals_ = 0;
  ros::Time bag_time_;
  ros::Time latest_tf_stamp_;
  std::map<ros::Time, Detection2DArray::ConstPtr> detections_;
  std::map<ros::Time, ProjectedGrid::ConstPtr> projections_;
};

/// Topic names of the inputs (kitti2bag's by default).
struct PipelineTopics
{
  std::string points = "/kitti/velo/pointcloud";
  std::string image = "/kitti/camera_color_left/image_raw";
  std::string camera_info = "/kitti/camera_color_left/camera_info";
  std::string tf = "/tf";
  std::string tf_static = "/tf_static";
};

/// What runPipelineOnBag() did.
struct BagRunSummary
{
  std::size_t messages_read = 0;
  std::size_t frames = 0;       ///< images read
  double bag_duration_s = 0.0;  ///< from the first to the last message read
  double wall_s = 0.0;          ///< wall time of the whole run (reading and writing included)
  std::vector<double> rss_mb;   ///< resident memory after every image [MiB]
};

/// Reads `input_bag` in time order, feeds `pipeline`, calls `progress(done, total)` per message
/// (may be empty). @throws std::runtime_error naming the bag when it cannot be read (with the
/// `rosbag reindex` hint of bagReadError()) or holds none of the input topics.
BagRunSummary runPipelineOnBag(Pipeline& pipeline, const std::string& input_bag, const PipelineTopics& topics,
                               const std::function<void(std::size_t, std::size_t)>& progress = nullptr);

/// Resident memory of this process now [MiB] (from /proc/self/statm; 0 when unknown).
double residentMemoryMiB();
/// Peak resident memory of this process so far [MiB] (getrusage).
double peakResidentMemoryMiB();

}  // namespace grid_vision_fusion
