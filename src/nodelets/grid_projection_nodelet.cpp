// grid_vision_fusion/grid_projection: DynamicGrid + CameraInfo (+ tf) -> ProjectedGrid, one per
// camera_info, stamped like the image. Each camera_info first waits (without blocking) for the
// grid of its own sweep (GridForImage), then in a TfWaitQueue until the tf of its stamp is
// there: a camera_info that arrives before its grid or before the /tf of the same stamp is
// projected as soon as they come in.
#include <cv_bridge/cv_bridge.h>
#include <image_transport/image_transport.h>
#include <nodelet/nodelet.h>
#include <ros/ros.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/image_encodings.h>
#include <std_msgs/Header.h>
#include <tf2/exceptions.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_listener.h>
#include <boost/make_shared.hpp>
#include <boost/thread/lock_guard.hpp>
#include <boost/thread/mutex.hpp>
#include <pluginlib/class_list_macros.hpp>

#include <deque>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "grid_vision_fusion/DynamicGrid.h"
#include "grid_vision_fusion/ProjectedGrid.h"
#include "grid_vision_fusion/fusion/overlay.h"
#include "grid_vision_fusion/ros/fusion_conversions.h"
#include "grid_vision_fusion/ros/projection_conversions.h"
#include "grid_vision_fusion/ros/sensor_views.h"
#include "grid_vision_fusion/ros_stages/projection_stage.h"
#include "grid_vision_fusion/ros_sync/grid_for_image.h"
#include "grid_vision_fusion/ros_sync/stage_diagnostics.h"
#include "grid_vision_fusion/ros_sync/stamp_cadence.h"
#include "grid_vision_fusion/ros_sync/tf_wait_queue.h"

namespace grid_vision_fusion
{
namespace
{
constexpr double kThrottleS = 5.0;
/// camera_infos waiting for the manager's threads: under load a queue of a few would lose them
/// silently in roscpp, and each one is small and projected in under a millisecond.
constexpr std::uint32_t kInfoQueueSize = 30;

/// A camera_info with the grid it is projected with; it waits in the tf queue for the tf from
/// the camera_info's frame (`header`, the camera_info's) to `frames` (the grid frame and
/// ground_frame) at its stamp.
struct ProjectionRequest
{
  std_msgs::Header header;
  sensor_msgs::CameraInfo::ConstPtr info;
  DynamicGrid::ConstPtr grid;
  std::vector<std::string> frames;
};
}  // namespace

class GridProjectionNodelet : public nodelet::Nodelet
{
  using Pairing = GridForImage<DynamicGrid, sensor_msgs::CameraInfo>;
  using TfQueue = TfWaitQueue<ProjectionRequest>;

  void onInit() override;
  void connectCb();
  void gridCb(const DynamicGrid::ConstPtr& grid_msg);
  /// camera_info as received: waits in pairing_ for the grid of its sweep.
  void cameraInfoInCb(const sensor_msgs::CameraInfo::ConstPtr& info_msg);
  /// Hands camera_infos paired with their grid to the tf queue.
  void queuePairs(const std::vector<Pairing::Pair>& pairs);
  /// A camera_info whose tf (camera <- grid frame, ground_frame) is available at its stamp.
  void project(const boost::shared_ptr<const ProjectionRequest>& request);
  void tfFailureCb(const boost::shared_ptr<const ProjectionRequest>& request, TfWaitDrop reason);
  void imageCb(const sensor_msgs::Image::ConstPtr& image_msg);
  /// Publishes the overlay of the cached image and projection with equal stamps, if any.
  void publishMatchedOverlay();

  boost::mutex connect_mutex_;
  std::unique_ptr<ProjectionStage> stage_;
  std::unique_ptr<StageDiagnostics> diagnostics_;  // the flow on /diagnostics, fed by the callbacks below

  std::unique_ptr<tf2_ros::Buffer> tf_buffer_;
  std::unique_ptr<tf2_ros::TransformListener> tf_listener_;
  std::unique_ptr<TfQueue> tf_queue_;
  std::unique_ptr<TfWaitPolling> tf_polling_;  // declared after the queue it polls
  std::unique_ptr<Pairing> pairing_;
  StampCadence grid_cadence_;  // how far apart the grids come: the age a grid may have (maxGridAge)

  std::unique_ptr<image_transport::ImageTransport> it_;
  ros::Subscriber sub_grid_;
  ros::Subscriber sub_info_;
  image_transport::Subscriber sub_image_;

  std::mutex overlay_mutex_;
  std::deque<sensor_msgs::Image::ConstPtr> images_;
  std::deque<ProjectedGrid::ConstPtr> projections_;

  ros::Publisher pub_projected_;
  image_transport::Publisher pub_image_;
};

void GridProjectionNodelet::onInit()
{
  ros::NodeHandle& nh = getNodeHandle();
  ros::NodeHandle& pnh = getPrivateNodeHandle();
  std::vector<std::string> unknown;
  try
  {
    stage_ = std::make_unique<ProjectionStage>(
        GridProjectionParams::fromParams(NodeHandleParamSource(pnh), &unknown));
  }
  catch (const std::exception& e)
  {
    NODELET_ERROR(
        "grid_projection: cannot start, the nodelet is not loaded (the manager runs on; a loader started "
        "with "
        "required=\"true\" ends its launch): %s",
        e.what());
    throw;
  }
  for (const std::string& warning : unknown)
  {
    NODELET_WARN("grid_projection: %s", warning.c_str());
  }
  const GridProjectionParams& params = stage_->params();
  const GridProjectionConfig& config = params.projection;

  diagnostics_ = std::make_unique<StageDiagnostics>(
      nh, pnh, getName(), "none",
      std::vector<std::pair<std::string, std::string>>{{"grids", "grid"}, {"camera_infos", "camera_info"}});
  tf_buffer_ = std::make_unique<tf2_ros::Buffer>();
  tf_listener_ = std::make_unique<tf2_ros::TransformListener>(*tf_buffer_, nh);
  pairing_ = std::make_unique<Pairing>(params.grid_sync_tolerance);
  tf_queue_ = std::make_unique<TfQueue>(
      *tf_buffer_, static_cast<std::size_t>(params.queue_size),
      [this](const boost::shared_ptr<const ProjectionRequest>& request) { project(request); },
      [this](const boost::shared_ptr<const ProjectionRequest>& request, TfWaitDrop reason)
      { tfFailureCb(request, reason); },
      [](const ProjectionRequest& request) { return request.frames; });
  tf_polling_ = std::make_unique<TfWaitPolling>(*tf_buffer_, nh, [this] { tf_queue_->poll(); });

  it_ = std::make_unique<image_transport::ImageTransport>(nh);
  ros::SubscriberStatusCallback connect_cb = boost::bind(&GridProjectionNodelet::connectCb, this);
  image_transport::SubscriberStatusCallback image_connect_cb =
      boost::bind(&GridProjectionNodelet::connectCb, this);
  boost::lock_guard<boost::mutex> lock(connect_mutex_);
  pub_projected_ = nh.advertise<ProjectedGrid>("projected_grid", kResultQueueSize, connect_cb, connect_cb);
  pub_image_ = it_->advertise("projected_grid/image", 1, image_connect_cb, image_connect_cb);
  if (!params.lazy)
  {
    // connectCb takes the lock itself; subscribe without it here.
    sub_grid_ = nh.subscribe("grid", 1, &GridProjectionNodelet::gridCb, this);
    sub_info_ = nh.subscribe("camera_info", kInfoQueueSize, &GridProjectionNodelet::cameraInfoInCb, this);
    sub_image_ = it_->subscribe("image", 2, &GridProjectionNodelet::imageCb, this,
                                image_transport::TransportHints("raw", ros::TransportHints(), pnh));
  }
  NODELET_INFO(
      "grid_projection: occupied >= %.2f, dynamic when P(D) > %.2f (P(S)+P(D)), ground %.2f m %s%s, "
      "%s, prediction to the image stamp %s, max grid age %.2f s, grid sync tolerance %.3f s%s, %s",
      config.occupied_threshold, config.dynamic_ratio, params.ground_height,
      params.ground_frame.empty() ? "in the grid frame" : "below/above the origin of ",
      params.ground_frame.c_str(), config.column_mode ? "column mode" : "ground points only",
      config.predict_to_image_stamp ? "on" : "off", params.max_grid_age, params.grid_sync_tolerance,
      params.grid_sync_tolerance < 0.0 ? " (no waiting)" : "", params.lazy ? "lazy" : "always subscribed");
}

void GridProjectionNodelet::connectCb()
{
  boost::lock_guard<boost::mutex> lock(connect_mutex_);
  const GridProjectionParams& params = stage_->params();
  if (!params.lazy)
  {
    return;
  }
  ros::NodeHandle& nh = getNodeHandle();
  const bool overlay_wanted = pub_image_.getNumSubscribers() > 0;
  const bool any_output = overlay_wanted || pub_projected_.getNumSubscribers() > 0;
  if (!any_output)
  {
    sub_grid_.shutdown();
    sub_info_.shutdown();
    tf_queue_->clear();
    pairing_->clear();
    grid_cadence_.clear();
  }
  else if (!sub_grid_)
  {
    sub_grid_ = nh.subscribe("grid", 1, &GridProjectionNodelet::gridCb, this);
    sub_info_ = nh.subscribe("camera_info", kInfoQueueSize, &GridProjectionNodelet::cameraInfoInCb, this);
  }
  if (!overlay_wanted)
  {
    sub_image_.shutdown();
    std::lock_guard<std::mutex> overlay_lock(overlay_mutex_);
    images_.clear();
    projections_.clear();
  }
  else if (!sub_image_)
  {
    sub_image_ =
        it_->subscribe("image", 2, &GridProjectionNodelet::imageCb, this,
                       image_transport::TransportHints("raw", ros::TransportHints(), getPrivateNodeHandle()));
  }
}

void GridProjectionNodelet::gridCb(const DynamicGrid::ConstPtr& grid_msg)
{
  diagnostics_->input("grids");
  const std::string error = checkDynamicGrid(*grid_msg);
  if (!error.empty())
  {
    diagnostics_->drop("unusable grid", error);
    NODELET_WARN_THROTTLE(kThrottleS, "grid_projection: dropping the grid at t=%.3f on %s: %s",
                          grid_msg->header.stamp.toSec(), sub_grid_.getTopic().c_str(), error.c_str());
    return;
  }
  grid_cadence_.add(grid_msg->header.stamp);
  const DynamicGrid::ConstPtr newest = pairing_->newestGrid();
  if (newest && grid_msg->header.stamp < newest->header.stamp)
  {
    NODELET_WARN_THROTTLE(
        kThrottleS, "grid_projection: time jumped backwards on %s (%.3f after %.3f): grid replaced",
        sub_grid_.getTopic().c_str(), grid_msg->header.stamp.toSec(), newest->header.stamp.toSec());
  }
  queuePairs(pairing_->addGrid(grid_msg));
}

void GridProjectionNodelet::cameraInfoInCb(const sensor_msgs::CameraInfo::ConstPtr& info_msg)
{
  diagnostics_->input("camera_infos");
  queuePairs(pairing_->addInfo(info_msg));
}

void GridProjectionNodelet::queuePairs(const std::vector<Pairing::Pair>& pairs)
{
  for (const Pairing::Pair& pair : pairs)
  {
    if (!pair.grid)
    {
      diagnostics_->drop("no grid yet");
      NODELET_WARN_THROTTLE(kThrottleS,
                            "grid_projection: camera_info at t=%.3f but no grid received yet on %s",
                            pair.info->header.stamp.toSec(), sub_grid_.getTopic().c_str());
      continue;
    }
    // Waits in the queue (at most ~queue_size requests) until the tf of its stamp is there;
    // project or tfFailureCb follows.
    tf_queue_->add(boost::make_shared<const ProjectionRequest>(ProjectionRequest{
        pair.info->header, pair.info, pair.grid, stage_->tfFrames(pair.grid->header.frame_id)}));
  }
}

void GridProjectionNodelet::tfFailureCb(const boost::shared_ptr<const ProjectionRequest>& request,
                                        TfWaitDrop reason)
{
  const sensor_msgs::CameraInfo::ConstPtr& info_msg = request->info;
  const char* why = reason == TfWaitDrop::kEmptyFrameId
                        ? "the camera_info has an empty frame_id"
                        : "its tf did not arrive within ~queue_size camera_infos";
  diagnostics_->drop("no tf",
                     "'" + info_msg->header.frame_id + "' <- " + joinFrames(request->frames) + ": " + why);
  NODELET_WARN_THROTTLE(
      kThrottleS,
      "grid_projection: dropping the camera_info of %s at t=%.3f: no tf '%s' <- %s at its stamp "
      "(%s), nothing published",
      sub_info_.getTopic().c_str(), info_msg->header.stamp.toSec(), info_msg->header.frame_id.c_str(),
      joinFrames(request->frames).c_str(), why);
}

void GridProjectionNodelet::project(const boost::shared_ptr<const ProjectionRequest>& request)
{
  const DynamicGrid& grid = *request->grid;
  const sensor_msgs::CameraInfo::ConstPtr& info_msg = request->info;
  ProjectedGrid::Ptr projected;
  ProjectionNotes notes;
  try
  {
    projected = stage_->project(grid, *info_msg, *tf_buffer_, &notes, grid_cadence_.interval());
  }
  catch (const ProjectionSkipped& e)
  {
    diagnostics_->drop("projection skipped", e.what());
    NODELET_WARN_THROTTLE(kThrottleS,
                          "grid_projection: camera_info of %s at t=%.3f with the grid of %s: %s; nothing "
                          "published",
                          sub_info_.getTopic().c_str(), info_msg->header.stamp.toSec(),
                          sub_grid_.getTopic().c_str(), e.what());
    return;
  }
  if (notes.invalid_cells > 0)
  {
    NODELET_WARN_THROTTLE(kThrottleS,
                          "grid_projection: %zu cells of the grid on %s skipped (NaN/Inf probability or "
                          "velocity)",
                          notes.invalid_cells, sub_grid_.getTopic().c_str());
  }
  if (!notes.cells_left_out.empty())
  {
    diagnostics_->drop("cells left out: grid too old", notes.cells_left_out);
    NODELET_WARN_THROTTLE(
        kThrottleS,
        "grid_projection: camera_info of %s at t=%.3f with the grid of %s: %s; published "
        "without cells (its detections come out placed by their tracks or boxes, motion unknown)",
        sub_info_.getTopic().c_str(), info_msg->header.stamp.toSec(), sub_grid_.getTopic().c_str(),
        notes.cells_left_out.c_str());
  }
  if (pub_image_.getNumSubscribers() > 0)
  {
    {
      std::lock_guard<std::mutex> lock(overlay_mutex_);
      projections_.push_back(projected);
      while (projections_.size() > static_cast<std::size_t>(stage_->params().image_cache_size))
      {
        projections_.pop_front();
      }
    }
    publishMatchedOverlay();
  }
  pub_projected_.publish(projected);
  diagnostics_->output(info_msg->header.stamp);
}

void GridProjectionNodelet::imageCb(const sensor_msgs::Image::ConstPtr& image_msg)
{
  const std::string error = checkImageData(*image_msg);
  if (!error.empty())
  {
    NODELET_ERROR_THROTTLE(kThrottleS,
                           "grid_projection: image on %s at t=%.3f dropped (no overlay for it): %s",
                           sub_image_.getTopic().c_str(), image_msg->header.stamp.toSec(), error.c_str());
    return;
  }
  {
    std::lock_guard<std::mutex> lock(overlay_mutex_);
    images_.push_back(image_msg);
    while (images_.size() > static_cast<std::size_t>(stage_->params().image_cache_size))
    {
      images_.pop_front();
    }
  }
  publishMatchedOverlay();
}

void GridProjectionNodelet::publishMatchedOverlay()
{
  sensor_msgs::Image::ConstPtr image_msg;
  ProjectedGrid::ConstPtr projected;
  {
    std::lock_guard<std::mutex> lock(overlay_mutex_);
    for (std::size_t i = 0; i < images_.size() && !projected; ++i)
    {
      for (std::size_t j = 0; j < projections_.size(); ++j)
      {
        if (projections_[j]->header.stamp == images_[i]->header.stamp)
        {
          image_msg = images_[i];
          projected = projections_[j];
          images_.erase(images_.begin() + static_cast<std::ptrdiff_t>(i));
          projections_.erase(projections_.begin() + static_cast<std::ptrdiff_t>(j));
          break;
        }
      }
    }
  }
  if (!projected)
  {
    return;
  }
  cv_bridge::CvImagePtr canvas;
  try
  {
    canvas = cv_bridge::toCvCopy(image_msg, sensor_msgs::image_encodings::BGR8);
  }
  catch (const cv_bridge::Exception& e)
  {
    NODELET_ERROR_THROTTLE(kThrottleS, "grid_projection: cannot draw on image of encoding '%s' from %s: %s",
                           image_msg->encoding.c_str(), sub_image_.getTopic().c_str(), e.what());
    return;
  }
  if (canvas->image.cols != static_cast<int>(projected->image_width) ||
      canvas->image.rows != static_cast<int>(projected->image_height))
  {
    NODELET_WARN_THROTTLE(kThrottleS, "grid_projection: image on %s is %dx%d but camera_info says %ux%u",
                          sub_image_.getTopic().c_str(), canvas->image.cols, canvas->image.rows,
                          projected->image_width, projected->image_height);
  }
  drawProjectedPoints(canvas->image, viewOf(*projected));
  pub_image_.publish(canvas->toImageMsg());
}

}  // namespace grid_vision_fusion

PLUGINLIB_EXPORT_CLASS(grid_vision_fusion::GridProjectionNodelet, nodelet::Nodelet)
