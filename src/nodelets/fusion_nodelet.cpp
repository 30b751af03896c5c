// grid_vision_fusion/fusion: detector boxes + projected grid -> DetectedObjectArray.
#include <cv_bridge/cv_bridge.h>
#include <dynamic_reconfigure/server.h>
#include <image_transport/image_transport.h>
#include <message_filters/subscriber.h>
#include <message_filters/sync_policies/approximate_time.h>
#include <message_filters/sync_policies/exact_time.h>
#include <message_filters/synchronizer.h>
#include <nodelet/nodelet.h>
#include <ros/ros.h>
#include <sensor_msgs/image_encodings.h>
#include <visualization_msgs/MarkerArray.h>
#include <boost/make_shared.hpp>
#include <boost/thread/lock_guard.hpp>
#include <boost/thread/mutex.hpp>
#include <pluginlib/class_list_macros.hpp>

#include <deque>
#include <memory>
#include <mutex>

#include "grid_vision_fusion/DetectedObjectArray.h"
#include "grid_vision_fusion/Detection2DArray.h"
#include "grid_vision_fusion/FusionReconfigureConfig.h"
#include "grid_vision_fusion/ProjectedGrid.h"
#include "grid_vision_fusion/fusion/overlay.h"
#include "grid_vision_fusion/ros/fusion_conversions.h"
#include "grid_vision_fusion/ros/sensor_views.h"
#include "grid_vision_fusion/ros_stages/fusion_stage.h"
#include "grid_vision_fusion/ros_sync/stage_diagnostics.h"

namespace grid_vision_fusion
{
namespace
{
constexpr double kThrottleS = 5.0;
}  // namespace

class FusionNodelet : public nodelet::Nodelet
{
  using ExactPolicy = message_filters::sync_policies::ExactTime<Detection2DArray, ProjectedGrid>;
  using ApproximatePolicy = message_filters::sync_policies::ApproximateTime<Detection2DArray, ProjectedGrid>;
  using ReconfigureServer = dynamic_reconfigure::Server<FusionReconfigureConfig>;

  void onInit() override;
  void connectCb();
  void fusionCb(const Detection2DArray::ConstPtr& detections_msg, const ProjectedGrid::ConstPtr& grid_msg);
  /// A message the exact-time synchroniser gives up on: its partner of the same stamp never came
  /// (the other branch dropped that frame, e.g. under overload) before newer pairs did.
  void unpairedCb(const Detection2DArray::ConstPtr& detections_msg, const ProjectedGrid::ConstPtr& grid_msg);
  void imageCb(const sensor_msgs::Image::ConstPtr& image_msg);
  void reconfigureCb(FusionReconfigureConfig& reconfigure, uint32_t level);
  void publishOverlay(const Detection2DArray& detections_msg, const std::vector<Detection>& detections,
                      const FusionResult& result, const ProjectedPointsView& points,
                      const FusionConfig& config);

  boost::mutex connect_mutex_;
  std::mutex stage_mutex_;  // the stage (its configuration changes with dynamic_reconfigure)
  std::unique_ptr<FusionStage> stage_;
  std::unique_ptr<StageDiagnostics> diagnostics_;  // the flow on /diagnostics, fed by the callbacks below

  std::unique_ptr<image_transport::ImageTransport> it_;
  message_filters::Subscriber<Detection2DArray> sub_detections_;
  message_filters::Subscriber<ProjectedGrid> sub_grid_;
  std::unique_ptr<message_filters::Synchronizer<ExactPolicy>> exact_sync_;
  std::unique_ptr<message_filters::Synchronizer<ApproximatePolicy>> approximate_sync_;
  image_transport::Subscriber sub_image_;
  std::mutex image_mutex_;
  std::deque<sensor_msgs::Image::ConstPtr> image_cache_;

  ros::Publisher pub_objects_;
  ros::Publisher pub_markers_;
  image_transport::Publisher pub_image_;
  std::unique_ptr<ReconfigureServer> reconfigure_server_;
};

void FusionNodelet::onInit()
{
  ros::NodeHandle& nh = getNodeHandle();
  ros::NodeHandle& pnh = getPrivateNodeHandle();

  std::vector<std::string> unknown;
  try
  {
    stage_ = std::make_unique<FusionStage>(FusionParams::fromParams(NodeHandleParamSource(pnh), &unknown));
  }
  catch (const std::exception& e)
  {
    NODELET_ERROR(
        "fusion: cannot start, the nodelet is not loaded (the manager runs on; a loader started with "
        "required=\"true\" ends its launch): %s",
        e.what());
    throw;
  }
  for (const std::string& warning : unknown)
  {
    NODELET_WARN("fusion: %s", warning.c_str());
  }
  for (const std::string& warning : stage_->params().perFrameOptionsIgnored())
  {
    NODELET_WARN("fusion: %s", warning.c_str());
  }
  const FusionParams& params = stage_->params();
  const bool approximate_sync = params.approximate_sync;

  reconfigure_server_ = std::make_unique<ReconfigureServer>(pnh);
  reconfigure_server_->setCallback(
      boost::bind(&FusionNodelet::reconfigureCb, this, boost::placeholders::_1, boost::placeholders::_2));

  diagnostics_ = std::make_unique<StageDiagnostics>(
      nh, pnh, getName(), "none",
      std::vector<std::pair<std::string, std::string>>{{"detections", "detections"},
                                                       {"projected grids", "projected_grid"}});
  sub_detections_.registerCallback(boost::function<void(const Detection2DArray::ConstPtr&)>(
      [this](const Detection2DArray::ConstPtr&) { diagnostics_->input("detections"); }));
  sub_grid_.registerCallback(boost::function<void(const ProjectedGrid::ConstPtr&)>(
      [this](const ProjectedGrid::ConstPtr&) { diagnostics_->input("projected grids"); }));

  if (approximate_sync)
  {
    approximate_sync_ = std::make_unique<message_filters::Synchronizer<ApproximatePolicy>>(
        ApproximatePolicy(params.queue_size), sub_detections_, sub_grid_);
    approximate_sync_->registerCallback(
        boost::bind(&FusionNodelet::fusionCb, this, boost::placeholders::_1, boost::placeholders::_2));
  }
  else
  {
    exact_sync_ = std::make_unique<message_filters::Synchronizer<ExactPolicy>>(ExactPolicy(params.queue_size),
                                                                               sub_detections_, sub_grid_);
    exact_sync_->registerCallback(
        boost::bind(&FusionNodelet::fusionCb, this, boost::placeholders::_1, boost::placeholders::_2));
    exact_sync_->registerDropCallback(
        boost::bind(&FusionNodelet::unpairedCb, this, boost::placeholders::_1, boost::placeholders::_2));
  }

  it_ = std::make_unique<image_transport::ImageTransport>(nh);
  ros::SubscriberStatusCallback connect_cb = boost::bind(&FusionNodelet::connectCb, this);
  image_transport::SubscriberStatusCallback image_connect_cb = boost::bind(&FusionNodelet::connectCb, this);
  boost::lock_guard<boost::mutex> lock(connect_mutex_);
  pub_objects_ = nh.advertise<DetectedObjectArray>("objects", kResultQueueSize, connect_cb, connect_cb);
  pub_markers_ = nh.advertise<visualization_msgs::MarkerArray>("objects/markers", 1, connect_cb, connect_cb);
  pub_image_ = it_->advertise("objects/image", 1, image_connect_cb, image_connect_cb);
  if (!params.lazy)
  {
    // connectCb takes the lock itself; subscribe without it here.
    sub_detections_.subscribe(nh, "detections", params.queue_size);
    sub_grid_.subscribe(nh, "projected_grid", params.queue_size);
    sub_image_ = it_->subscribe("image", 2, &FusionNodelet::imageCb, this,
                                image_transport::TransportHints("raw", ros::TransportHints(), pnh));
  }
  NODELET_INFO(
      "fusion: band [-%.2f h, +%.2f h] around the box bottom, min_points %d, tie rule %s, motion vote %s, "
      "position %s, tracking %s, %s sync, %s",
      params.fusion.band_above, params.fusion.band_below, params.fusion.min_points,
      toString(params.fusion.tie_rule).c_str(), toString(params.fusion.motion_vote).c_str(),
      toString(params.fusion.position).c_str(), params.tracking ? "on" : "off",
      approximate_sync ? "approximate" : "exact", params.lazy ? "lazy" : "always subscribed");
}

void FusionNodelet::connectCb()
{
  boost::lock_guard<boost::mutex> lock(connect_mutex_);
  const FusionParams& params = stage_->params();
  if (!params.lazy)
  {
    return;
  }
  ros::NodeHandle& nh = getNodeHandle();
  const bool overlay_wanted = pub_image_.getNumSubscribers() > 0;
  const bool any_output =
      overlay_wanted || pub_objects_.getNumSubscribers() > 0 || pub_markers_.getNumSubscribers() > 0;
  if (!any_output)
  {
    sub_detections_.unsubscribe();
    sub_grid_.unsubscribe();
  }
  else if (!sub_detections_.getSubscriber())
  {
    sub_detections_.subscribe(nh, "detections", params.queue_size);
    sub_grid_.subscribe(nh, "projected_grid", params.queue_size);
  }
  if (!overlay_wanted)
  {
    sub_image_.shutdown();
    std::lock_guard<std::mutex> image_lock(image_mutex_);
    image_cache_.clear();
  }
  else if (!sub_image_)
  {
    sub_image_ =
        it_->subscribe("image", 2, &FusionNodelet::imageCb, this,
                       image_transport::TransportHints("raw", ros::TransportHints(), getPrivateNodeHandle()));
  }
}

void FusionNodelet::reconfigureCb(FusionReconfigureConfig& reconfigure, uint32_t /*level*/)
{
  std::lock_guard<std::mutex> lock(stage_mutex_);
  FusionConfig updated = stage_->config();
  updated.band_above = reconfigure.band_above;
  updated.band_below = reconfigure.band_below;
  try
  {
    stage_->setConfig(updated);
  }
  catch (const std::invalid_argument& e)
  {
    NODELET_ERROR("fusion: reconfiguration refused: %s", e.what());
  }
}

void FusionNodelet::imageCb(const sensor_msgs::Image::ConstPtr& image_msg)
{
  const std::string error = checkImageData(*image_msg);
  if (!error.empty())
  {
    NODELET_ERROR_THROTTLE(kThrottleS, "fusion: image on %s at t=%.3f dropped (no overlay for it): %s",
                           sub_image_.getTopic().c_str(), image_msg->header.stamp.toSec(), error.c_str());
    return;
  }
  std::lock_guard<std::mutex> lock(image_mutex_);
  image_cache_.push_back(image_msg);
  while (image_cache_.size() > static_cast<std::size_t>(stage_->params().image_cache_size))
  {
    image_cache_.pop_front();
  }
}

void FusionNodelet::unpairedCb(const Detection2DArray::ConstPtr& detections_msg,
                               const ProjectedGrid::ConstPtr& /*grid_msg*/)
{
  // Only a detection without its grid loses a frame's objects; a projected grid without
  // detections is a frame the detector did not process (its drops are counted there).
  if (detections_msg)
  {
    diagnostics_->drop("detections without the projected grid of their image");
  }
}

void FusionNodelet::fusionCb(const Detection2DArray::ConstPtr& detections_msg,
                             const ProjectedGrid::ConstPtr& grid_msg)
{
  FusionConfig config;
  FusedPair pair;
  try
  {
    std::lock_guard<std::mutex> lock(stage_mutex_);
    config = stage_->config();
    pair = stage_->fuse(*detections_msg, *grid_msg);
  }
  catch (const std::invalid_argument& e)
  {
    diagnostics_->drop("pair refused", e.what());
    NODELET_WARN_THROTTLE(kThrottleS, "fusion: dropping the pair at t=%.3f (%s + %s): %s",
                          detections_msg->header.stamp.toSec(), sub_detections_.getTopic().c_str(),
                          sub_grid_.getTopic().c_str(), e.what());
    return;
  }
  if (!pair.tracks_reset.empty())
  {
    NODELET_WARN_THROTTLE(kThrottleS, "fusion: tracks reset at t=%.3f (%s): %s",
                          detections_msg->header.stamp.toSec(), sub_detections_.getTopic().c_str(),
                          pair.tracks_reset.c_str());
  }
  if (pair.unplaced > 0)
  {
    NODELET_WARN_THROTTLE(
        kThrottleS,
        "fusion: %zu boxes without grid cells left out at t=%.3f: %s carries no grid_to_image "
        "(a producer older than the field), so nothing says where they stand",
        pair.unplaced, detections_msg->header.stamp.toSec(), sub_grid_.getTopic().c_str());
  }
  const std::vector<Detection>& detections = pair.detections;
  const FusionResult& result = pair.result;
  const ProjectedPointsView points = viewOf(*grid_msg);
  if (result.invalid_points > 0)
  {
    NODELET_WARN_THROTTLE(kThrottleS, "fusion: %zu of %zu points of %s ignored (NaN/Inf values or bad state)",
                          result.invalid_points, points.size, sub_grid_.getTopic().c_str());
  }

  const DetectedObjectArray::Ptr& objects = pair.objects;
  if (pub_markers_.getNumSubscribers() > 0)
  {
    pub_markers_.publish(objectsToMarkers(*objects, result.tracked));
  }
  if (pub_image_.getNumSubscribers() > 0)
  {
    publishOverlay(*detections_msg, detections, result, points, config);
  }
  pub_objects_.publish(objects);
  diagnostics_->output(detections_msg->header.stamp);
}

void FusionNodelet::publishOverlay(const Detection2DArray& detections_msg,
                                   const std::vector<Detection>& detections, const FusionResult& result,
                                   const ProjectedPointsView& points, const FusionConfig& config)
{
  sensor_msgs::Image::ConstPtr image_msg;
  {
    std::lock_guard<std::mutex> lock(image_mutex_);
    for (const auto& cached : image_cache_)
    {
      if (cached->header.stamp == detections_msg.header.stamp)
      {
        image_msg = cached;
      }
    }
  }
  if (!image_msg)
  {
    NODELET_WARN_THROTTLE(kThrottleS, "fusion: no image on %s with stamp %.3f for the overlay",
                          sub_image_.getTopic().c_str(), detections_msg.header.stamp.toSec());
    return;
  }
  cv_bridge::CvImagePtr canvas;
  try
  {
    canvas = cv_bridge::toCvCopy(image_msg, sensor_msgs::image_encodings::BGR8);
  }
  catch (const cv_bridge::Exception& e)
  {
    NODELET_ERROR_THROTTLE(kThrottleS, "fusion: cannot draw on image of encoding '%s' from %s: %s",
                           image_msg->encoding.c_str(), sub_image_.getTopic().c_str(), e.what());
    return;
  }
  drawFusionOverlay(canvas->image, detections, result, points, config);
  pub_image_.publish(canvas->toImageMsg());
}

}  // namespace grid_vision_fusion

PLUGINLIB_EXPORT_CLASS(grid_vision_fusion::FusionNodelet, nodelet::Nodelet)
