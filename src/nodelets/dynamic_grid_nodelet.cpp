// grid_vision_fusion/dynamic_grid: lidar PointCloud2 + tf -> CMCDOT-style dynamic occupancy grid.
#include <dynamic_reconfigure/server.h>
#include <nav_msgs/OccupancyGrid.h>
#include <nodelet/nodelet.h>
#include <ros/ros.h>
#include <sensor_msgs/PointCloud2.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_listener.h>
#include <boost/thread/lock_guard.hpp>
#include <boost/thread/mutex.hpp>
#include <pluginlib/class_list_macros.hpp>

#include <chrono>
#include <memory>
#include <mutex>
#include <optional>

#include "grid_vision_fusion/DynamicGrid.h"
#include "grid_vision_fusion/DynamicGridReconfigureConfig.h"
#include "grid_vision_fusion/ros_stages/grid_stage.h"
#include "grid_vision_fusion/ros_sync/newest_slot.h"
#include "grid_vision_fusion/ros_sync/stage_diagnostics.h"
#include "grid_vision_fusion/ros_sync/tf_wait_queue.h"

namespace grid_vision_fusion
{
namespace
{
constexpr double kThrottleS = 5.0;
}  // namespace

class DynamicGridNodelet : public nodelet::Nodelet
{
public:
  ~DynamicGridNodelet() override;

private:
  using ReconfigureServer = dynamic_reconfigure::Server<DynamicGridReconfigureConfig>;
  using TfQueue = TfWaitQueue<sensor_msgs::PointCloud2>;

  void onInit() override;
  void connectCb();
  /// A cloud whose tf (fixed_frame <- cloud frame) is available at its stamp: into the slot.
  void cloudCb(const sensor_msgs::PointCloud2::ConstPtr& cloud_msg);
  /// The filter cycle for the newest cloud of the slot; `replaced`: the newest one dropped before it.
  void process(const sensor_msgs::PointCloud2::ConstPtr& cloud_msg,
               const std::optional<sensor_msgs::PointCloud2::ConstPtr>& replaced);
  void tfFailureCb(const sensor_msgs::PointCloud2::ConstPtr& cloud_msg, TfWaitDrop reason);
  void subscribePoints();
  void reconfigureCb(DynamicGridReconfigureConfig& reconfigure, uint32_t level);
  void diagnose(diagnostic_updater::DiagnosticStatusWrapper& status);

  boost::mutex connect_mutex_;
  std::mutex filter_mutex_;  // the stage and its statistics
  std::unique_ptr<GridStage> stage_;
  std::string fixed_frame_;
  // The flow on /diagnostics (reads the stage; the callbacks below feed it: declared between).
  std::unique_ptr<StageDiagnostics> diagnostics_;

  // The newest cloud with its tf, for the filter on the slot's own thread: a cloud that comes
  // while the filter is busy replaces a waiting one instead of queueing (overload).
  // Ended first in the destructor; destroyed after the tf queue that feeds it.
  std::unique_ptr<NewestSlot<sensor_msgs::PointCloud2::ConstPtr>> slot_;

  std::unique_ptr<tf2_ros::Buffer> tf_buffer_;
  std::unique_ptr<tf2_ros::TransformListener> tf_listener_;
  // The clouds waiting for their tf; what calls into the queue is declared after it (destroyed
  // before it).
  std::unique_ptr<TfQueue> tf_queue_;
  std::unique_ptr<TfWaitPolling> tf_polling_;
  ros::Subscriber sub_points_;

  ros::Publisher pub_grid_;
  ros::Publisher pub_occupancy_;
  ros::Publisher pub_cells_;
  std::unique_ptr<ReconfigureServer> reconfigure_server_;

  // Diagnostics figures (under filter_mutex_).
  double last_processing_ms_ = 0.0;
  double max_processing_ms_ = 0.0;
  std::size_t particles_in_use_ = 0;
  std::size_t scans_ = 0;
  std::size_t invalid_points_ = 0;
  std::size_t resets_ = 0;
  std::size_t tf_drops_ = 0;
  std::size_t unusable_clouds_ = 0;
};

DynamicGridNodelet::~DynamicGridNodelet()
{
  if (diagnostics_)
  {
    diagnostics_->stop();
  }
  sub_points_.shutdown();
  tf_polling_.reset();  // nothing hands the slot a cloud any more
  if (slot_)
  {
    slot_->end();  // waits for a running filter cycle; a waiting cloud is not filtered
  }
}

void DynamicGridNodelet::onInit()
{
  ros::NodeHandle& nh = getNodeHandle();
  ros::NodeHandle& pnh = getPrivateNodeHandle();

  std::vector<std::string> unknown;
  try
  {
    stage_ = std::make_unique<GridStage>(DynamicGridParams::fromParams(NodeHandleParamSource(pnh), &unknown));
  }
  catch (const std::exception& e)
  {
    NODELET_ERROR(
        "dynamic_grid: cannot start, the nodelet is not loaded (the manager runs on; a loader started with "
        "required=\"true\" ends its launch): %s",
        e.what());
    throw;
  }
  for (const std::string& warning : unknown)
  {
    NODELET_WARN("dynamic_grid: %s", warning.c_str());
  }
  const DynamicGridParams& params = stage_->params();
  const DynamicGridConfig& config = params.filter;
  fixed_frame_ = params.fixed_frame;

  reconfigure_server_ = std::make_unique<ReconfigureServer>(pnh);
  reconfigure_server_->setCallback(boost::bind(&DynamicGridNodelet::reconfigureCb, this,
                                               boost::placeholders::_1, boost::placeholders::_2));

  slot_ = std::make_unique<NewestSlot<sensor_msgs::PointCloud2::ConstPtr>>(
      "dynamic_grid", [this](const sensor_msgs::PointCloud2::ConstPtr& cloud,
                             const std::optional<sensor_msgs::PointCloud2::ConstPtr>& replaced)
      { process(cloud, replaced); });
  tf_buffer_ = std::make_unique<tf2_ros::Buffer>();
  tf_listener_ = std::make_unique<tf2_ros::TransformListener>(*tf_buffer_, nh);
  tf_queue_ = std::make_unique<TfQueue>(
      *tf_buffer_, static_cast<std::size_t>(params.queue_size),
      [this](const sensor_msgs::PointCloud2::ConstPtr& cloud) { cloudCb(cloud); },
      [this](const sensor_msgs::PointCloud2::ConstPtr& cloud, TfWaitDrop reason)
      { tfFailureCb(cloud, reason); });
  tf_queue_->setTargetFrames({fixed_frame_});
  tf_polling_ = std::make_unique<TfWaitPolling>(*tf_buffer_, nh, [this] { tf_queue_->poll(); });

  diagnostics_ = std::make_unique<StageDiagnostics>(
      nh, pnh, getName(), "none", std::vector<std::pair<std::string, std::string>>{{"scans", "points"}},
      [this](diagnostic_updater::DiagnosticStatusWrapper& status)
      {
        std::lock_guard<std::mutex> lock(filter_mutex_);
        diagnose(status);
      });

  ros::SubscriberStatusCallback connect_cb = boost::bind(&DynamicGridNodelet::connectCb, this);
  boost::lock_guard<boost::mutex> lock(connect_mutex_);
  pub_grid_ = nh.advertise<DynamicGrid>("grid", 1, connect_cb, connect_cb);
  pub_occupancy_ = nh.advertise<nav_msgs::OccupancyGrid>("grid/occupancy", 1, connect_cb, connect_cb);
  pub_cells_ = nh.advertise<sensor_msgs::PointCloud2>("grid/cells", 1, connect_cb, connect_cb);
  if (!params.lazy)
  {
    subscribePoints();
  }
  NODELET_INFO("dynamic_grid: %dx%d cells of %.2f m in %s, %d particles, seed %u, %s", config.width,
               config.height, config.resolution, fixed_frame_.c_str(), config.particle_count, config.seed,
               params.lazy ? "lazy" : "always subscribed");
}

void DynamicGridNodelet::connectCb()
{
  boost::lock_guard<boost::mutex> lock(connect_mutex_);
  if (!stage_->params().lazy)
  {
    return;
  }
  const bool any_output = pub_grid_.getNumSubscribers() > 0 || pub_occupancy_.getNumSubscribers() > 0 ||
                          pub_cells_.getNumSubscribers() > 0;
  if (!any_output)
  {
    sub_points_.shutdown();
  }
  else if (!sub_points_)
  {
    subscribePoints();
  }
}

void DynamicGridNodelet::subscribePoints()
{
  // Each cloud waits in the queue (at most ~queue_size) until the tf of its stamp is there;
  // cloudCb or tfFailureCb follows.
  sub_points_ = getNodeHandle().subscribe<sensor_msgs::PointCloud2>(
      "points", static_cast<std::uint32_t>(stage_->params().queue_size),
      [this](const sensor_msgs::PointCloud2::ConstPtr& cloud)
      {
        diagnostics_->input("scans");
        tf_queue_->add(cloud);
      });
}

void DynamicGridNodelet::reconfigureCb(DynamicGridReconfigureConfig& reconfigure, uint32_t /*level*/)
{
  std::lock_guard<std::mutex> lock(filter_mutex_);
  DynamicGridConfig thresholds = stage_->filter().config();
  thresholds.dynamic_threshold = reconfigure.dynamic_threshold;
  thresholds.min_dynamic_speed = reconfigure.min_dynamic_speed;
  thresholds.mahalanobis_threshold = reconfigure.mahalanobis_threshold;
  thresholds.occupied_threshold = reconfigure.occupied_threshold;
  try
  {
    stage_->setClassification(thresholds);
  }
  catch (const std::invalid_argument& e)
  {
    NODELET_ERROR("dynamic_grid: reconfiguration refused: %s", e.what());
  }
}

void DynamicGridNodelet::tfFailureCb(const sensor_msgs::PointCloud2::ConstPtr& cloud_msg, TfWaitDrop reason)
{
  {
    std::lock_guard<std::mutex> lock(filter_mutex_);
    ++tf_drops_;
  }
  const char* why = reason == TfWaitDrop::kEmptyFrameId ? "the cloud has an empty frame_id"
                                                        : "no transform within the queue";
  diagnostics_->drop("no tf", fixed_frame_ + " <- '" + cloud_msg->header.frame_id + "': " + why);
  NODELET_WARN_THROTTLE(kThrottleS,
                        "dynamic_grid: dropping the scan of %s at t=%.3f: no tf %s <- '%s' at its stamp (%s)",
                        sub_points_.getTopic().c_str(), cloud_msg->header.stamp.toSec(), fixed_frame_.c_str(),
                        cloud_msg->header.frame_id.c_str(), why);
}

void DynamicGridNodelet::cloudCb(const sensor_msgs::PointCloud2::ConstPtr& cloud_msg)
{
  if (slot_->offer(cloud_msg))
  {
    diagnostics_->drop("older scan replaced by a newer one (the filter is slower than the lidar)");
  }
}

void DynamicGridNodelet::process(const sensor_msgs::PointCloud2::ConstPtr& cloud_msg,
                                 const std::optional<sensor_msgs::PointCloud2::ConstPtr>& replaced)
{
  const auto start = std::chrono::steady_clock::now();
  std::lock_guard<std::mutex> lock(filter_mutex_);
  if (replaced)
  {
    // The filter predicts over the scans it had no time for instead of resetting as after an outage.
    stage_->skip(**replaced);
  }
  DynamicGridCycle cycle;
  try
  {
    cycle = stage_->update(*cloud_msg, *tf_buffer_);
  }
  catch (const UnusableMessage& e)
  {
    ++unusable_clouds_;
    diagnostics_->drop("unusable cloud", e.what());
    NODELET_ERROR_THROTTLE(kThrottleS,
                           "dynamic_grid: cannot use the clouds of %s (frame '%s', t=%.3f): %s; they need "
                           "float32 x, y, z fields, little-endian, and the data their size claims. Dropped.",
                           sub_points_.getTopic().c_str(), cloud_msg->header.frame_id.c_str(),
                           cloud_msg->header.stamp.toSec(), e.what());
    return;
  }
  catch (const tf2::TransformException& e)
  {
    ++tf_drops_;
    diagnostics_->drop("no tf", e.what());
    NODELET_WARN_THROTTLE(kThrottleS, "dynamic_grid: dropping the scan of %s: tf %s <- %s: %s",
                          sub_points_.getTopic().c_str(), fixed_frame_.c_str(),
                          cloud_msg->header.frame_id.c_str(), e.what());
    return;
  }
  if (cycle.reset)
  {
    ++resets_;
    NODELET_WARN("dynamic_grid: grid reset at t=%.3f (%s): %s", cloud_msg->header.stamp.toSec(),
                 sub_points_.getTopic().c_str(), cycle.reset_reason.c_str());
  }
  if (cycle.sensor.invalid_points > 0)
  {
    NODELET_WARN_THROTTLE(kThrottleS, "dynamic_grid: %zu of %zu points of %s dropped (NaN/Inf coordinates)",
                          cycle.sensor.invalid_points, cycle.sensor.points, sub_points_.getTopic().c_str());
  }
  if (cycle.sensor.points == 0)
  {
    NODELET_DEBUG_THROTTLE(kThrottleS, "dynamic_grid: empty cloud on %s: prediction step only",
                           sub_points_.getTopic().c_str());
  }
  invalid_points_ += cycle.sensor.invalid_points;
  particles_in_use_ = cycle.particles_in_use;
  ++scans_;

  if (pub_occupancy_.getNumSubscribers() > 0)
  {
    pub_occupancy_.publish(stage_->occupancyMsg());
  }
  if (pub_cells_.getNumSubscribers() > 0)
  {
    pub_cells_.publish(stage_->cellsMsg());
  }
  if (pub_grid_.getNumSubscribers() > 0)
  {
    pub_grid_.publish(stage_->gridMsg());
  }
  diagnostics_->output(cloud_msg->header.stamp);
  last_processing_ms_ =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  max_processing_ms_ = std::max(max_processing_ms_, last_processing_ms_);
}

void DynamicGridNodelet::diagnose(diagnostic_updater::DiagnosticStatusWrapper& status)
{
  const double budget_ms = 1e3 / stage_->params().expected_rate;
  if (scans_ > 0 && last_processing_ms_ > budget_ms)
  {
    status.mergeSummaryf(diagnostic_msgs::DiagnosticStatus::WARN,
                         "processing %.1f ms exceeds the scan period %.1f ms", last_processing_ms_,
                         budget_ms);
  }
  status.add("processing time last [ms]", last_processing_ms_);
  status.add("processing time max [ms]", max_processing_ms_);
  status.add("particles in use", particles_in_use_);
  status.add("particles", stage_->filter().config().particle_count);
  status.add("scans processed", scans_);
  status.add("points dropped (NaN/Inf)", invalid_points_);
  status.add("scans dropped (tf)", tf_drops_);
  status.add("scans dropped (unusable cloud)", unusable_clouds_);
  status.add("grid resets", resets_);
  status.add("fixed frame", fixed_frame_);
}

}  // namespace grid_vision_fusion

PLUGINLIB_EXPORT_CLASS(grid_vision_fusion::DynamicGridNodelet, nodelet::Nodelet)
