// grid_vision_fusion/yolo_detector: image → Detection2DArray, by a YOLO network on OpenCV DNN
// (backend "opencv_dnn") or from per-frame KITTI label files (backend "replay").
#include <cv_bridge/cv_bridge.h>
#include <dynamic_reconfigure/server.h>
#include <image_transport/image_transport.h>
#include <nodelet/nodelet.h>
#include <ros/ros.h>
#include <sensor_msgs/image_encodings.h>
#include <boost/thread/lock_guard.hpp>
#include <boost/thread/mutex.hpp>
#include <pluginlib/class_list_macros.hpp>

#include <chrono>
#include <memory>
#include <mutex>

#include "grid_vision_fusion/Detection2DArray.h"
#include "grid_vision_fusion/YoloDetectorReconfigureConfig.h"
#include "grid_vision_fusion/detection/yolo_detector.h"
#include "grid_vision_fusion/ros/detector_conversions.h"
#include "grid_vision_fusion/ros_stages/detector_stage.h"
#include "grid_vision_fusion/ros_sync/newest_slot.h"
#include "grid_vision_fusion/ros_sync/stage_diagnostics.h"

namespace grid_vision_fusion
{
namespace
{
constexpr double kThrottleS = 5.0;
}  // namespace

class YoloDetectorNodelet : public nodelet::Nodelet
{
public:
  ~YoloDetectorNodelet() override;

private:
  using ReconfigureServer = dynamic_reconfigure::Server<YoloDetectorReconfigureConfig>;

  /// An image waiting for inference, with the replay frame index given at its arrival.
  struct PendingFrame
  {
    sensor_msgs::Image::ConstPtr image;
    std::int64_t frame_index = -1;
  };

  void onInit() override;
  void connectCb();
  void imageCb(const sensor_msgs::Image::ConstPtr& image_msg);
  void process(const PendingFrame& frame);
  bool detect(const PendingFrame& frame, std::vector<Detection>& detections);
  void publishImage(const sensor_msgs::Image::ConstPtr& image_msg, const std::vector<Detection>& detections);
  void reconfigureCb(YoloDetectorReconfigureConfig& reconfigure, uint32_t level);
  void diagnose(diagnostic_updater::DiagnosticStatusWrapper& status);

  boost::mutex connect_mutex_;
  std::unique_ptr<DetectorStage> stage_;  // detect() by one process() at a time; frameIndex() by imageCb
  std::unique_ptr<StageDiagnostics> diagnostics_;  // the flow on /diagnostics, fed by the callbacks below

  std::mutex config_mutex_;  // guards the thresholds
  double score_threshold_ = 0.0;
  double nms_threshold_ = 0.0;

  /// The newest image for the inference on the slot's own thread: an image that comes during an
  /// inference replaces a waiting one.
  std::unique_ptr<NewestSlot<PendingFrame>> slot_;

  // Counters and timing for diagnostics.
  std::mutex stats_mutex_;
  std::uint64_t frames_received_ = 0;
  std::uint64_t frames_processed_ = 0;
  std::uint64_t frames_dropped_ = 0;
  std::uint64_t frames_failed_ = 0;
  std::uint64_t dropped_reported_ = 0;
  std::uint64_t failed_reported_ = 0;
  double last_inference_ms_ = 0.0;
  double total_inference_ms_ = 0.0;

  std::unique_ptr<image_transport::ImageTransport> it_;
  image_transport::Subscriber sub_image_;
  ros::Publisher pub_detections_;
  image_transport::Publisher pub_image_;
  std::unique_ptr<ReconfigureServer> reconfigure_server_;
};

YoloDetectorNodelet::~YoloDetectorNodelet()
{
  if (diagnostics_)
  {
    diagnostics_->stop();
  }
  sub_image_.shutdown();
  if (slot_)
  {
    slot_->end();  // waits for a running inference; a waiting image is not detected
  }
}

void YoloDetectorNodelet::onInit()
{
  ros::NodeHandle& nh = getNodeHandle();
  ros::NodeHandle& pnh = getPrivateNodeHandle();

  std::vector<std::string> unknown;
  try
  {
    stage_ =
        std::make_unique<DetectorStage>(DetectorParams::fromParams(NodeHandleParamSource(pnh), &unknown));
  }
  catch (const std::exception& e)
  {
    NODELET_ERROR(
        "yolo_detector: cannot start, the nodelet is not loaded (the manager runs on; a loader started with "
        "required=\"true\" ends its launch): %s",
        e.what());
    throw;
  }
  for (const std::string& warning : unknown)
  {
    NODELET_WARN("yolo_detector: %s", warning.c_str());
  }
  for (const std::string& warning : stage_->detector().warnings())
  {
    NODELET_WARN("yolo_detector: %s", warning.c_str());
  }
  const DetectorParams& params = stage_->params();
  score_threshold_ = params.yolo.score_threshold;
  nms_threshold_ = params.yolo.nms_threshold;

  diagnostics_ = std::make_unique<StageDiagnostics>(
      nh, pnh, getName(),
      params.backend == "replay" ? "replay " + params.replay.directory : params.yolo.model_path,
      std::vector<std::pair<std::string, std::string>>{{"images", "image"}},
      [this](diagnostic_updater::DiagnosticStatusWrapper& status) { diagnose(status); });

  slot_ = std::make_unique<NewestSlot<PendingFrame>>(
      "yolo_detector",
      [this](const PendingFrame& frame, const std::optional<PendingFrame>& /*replaced*/) { process(frame); });

  reconfigure_server_ = std::make_unique<ReconfigureServer>(pnh);
  reconfigure_server_->setCallback(boost::bind(&YoloDetectorNodelet::reconfigureCb, this,
                                               boost::placeholders::_1, boost::placeholders::_2));

  it_ = std::make_unique<image_transport::ImageTransport>(nh);
  ros::SubscriberStatusCallback connect_cb = boost::bind(&YoloDetectorNodelet::connectCb, this);
  image_transport::SubscriberStatusCallback image_connect_cb =
      boost::bind(&YoloDetectorNodelet::connectCb, this);
  boost::lock_guard<boost::mutex> lock(connect_mutex_);
  pub_detections_ = nh.advertise<Detection2DArray>("detections", kResultQueueSize, connect_cb, connect_cb);
  pub_image_ = it_->advertise("detections/image", 1, image_connect_cb, image_connect_cb);
  if (!params.lazy)
  {
    sub_image_ = it_->subscribe("image", 1, &YoloDetectorNodelet::imageCb, this,
                                image_transport::TransportHints("raw", ros::TransportHints(), pnh));
  }
  NODELET_INFO("yolo_detector: %s, score >= %.2f, NMS IoU %.2f, %s", stage_->detector().description().c_str(),
               score_threshold_, nms_threshold_, params.lazy ? "lazy" : "always subscribed");
}

void YoloDetectorNodelet::connectCb()
{
  boost::lock_guard<boost::mutex> lock(connect_mutex_);
  if (!stage_->params().lazy)
  {
    return;
  }
  const bool any_output = pub_detections_.getNumSubscribers() > 0 || pub_image_.getNumSubscribers() > 0;
  if (!any_output)
  {
    sub_image_.shutdown();
  }
  else if (!sub_image_)
  {
    sub_image_ =
        it_->subscribe("image", 1, &YoloDetectorNodelet::imageCb, this,
                       image_transport::TransportHints("raw", ros::TransportHints(), getPrivateNodeHandle()));
  }
}

void YoloDetectorNodelet::reconfigureCb(YoloDetectorReconfigureConfig& reconfigure, uint32_t /*level*/)
{
  std::lock_guard<std::mutex> lock(config_mutex_);
  score_threshold_ = reconfigure.score_threshold;
  nms_threshold_ = reconfigure.nms_threshold;
}

void YoloDetectorNodelet::imageCb(const sensor_msgs::Image::ConstPtr& image_msg)
{
  std::int64_t frame_index = -1;
  try
  {
    frame_index = stage_->frameIndex(*image_msg);
  }
  catch (const std::out_of_range& e)
  {
    NODELET_ERROR_THROTTLE(kThrottleS, "yolo_detector: image on %s at t=%.3f skipped: %s",
                           sub_image_.getTopic().c_str(), image_msg->header.stamp.toSec(), e.what());
    diagnostics_->drop("no frame index", e.what());
    return;
  }
  diagnostics_->input("images");
  {
    std::lock_guard<std::mutex> lock(stats_mutex_);
    ++frames_received_;
  }
  // Inference runs on the slot's thread; this callback returns at once so that the newest frame
  // always replaces a waiting one.
  if (slot_->offer({image_msg, frame_index}))
  {
    std::lock_guard<std::mutex> lock(stats_mutex_);
    ++frames_dropped_;  // inference is slower than the camera: the older frame is dropped
    diagnostics_->drop("older image replaced by a newer one (inference slower than the camera)");
  }
}

bool YoloDetectorNodelet::detect(const PendingFrame& frame, std::vector<Detection>& detections)
{
  const sensor_msgs::Image& image = *frame.image;
  double score_threshold = 0.0;
  double nms_threshold = 0.0;
  {
    std::lock_guard<std::mutex> lock(config_mutex_);
    score_threshold = score_threshold_;
    nms_threshold = nms_threshold_;
  }
  try
  {
    stage_->setThresholds(score_threshold, nms_threshold);
    detections = stage_->detect(frame.image, frame.frame_index);
    return true;
  }
  catch (const std::exception& e)
  {
    NODELET_ERROR_THROTTLE(kThrottleS, "yolo_detector: image on %s at t=%.3f (%ux%u, %s) not processed: %s",
                           sub_image_.getTopic().c_str(), image.header.stamp.toSec(), image.width,
                           image.height, image.encoding.c_str(), e.what());
    diagnostics_->drop("image not processed", e.what());
  }
  return false;
}

void YoloDetectorNodelet::process(const PendingFrame& frame)
{
  const auto start = std::chrono::steady_clock::now();
  std::vector<Detection> detections;
  const bool ok = detect(frame, detections);
  const double elapsed_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  {
    std::lock_guard<std::mutex> lock(stats_mutex_);
    if (ok)
    {
      ++frames_processed_;
      last_inference_ms_ = elapsed_ms;
      total_inference_ms_ += elapsed_ms;
    }
    else
    {
      ++frames_failed_;
    }
  }
  if (!ok)
  {
    return;
  }
  if (pub_image_.getNumSubscribers() > 0)
  {
    publishImage(frame.image, detections);
  }
  pub_detections_.publish(
      detectionsToMsg(frame.image->header, frame.image->width, frame.image->height, detections));
  diagnostics_->output(frame.image->header.stamp);
}

void YoloDetectorNodelet::publishImage(const sensor_msgs::Image::ConstPtr& image_msg,
                                       const std::vector<Detection>& detections)
{
  cv_bridge::CvImagePtr canvas;
  try
  {
    canvas = cv_bridge::toCvCopy(image_msg, sensor_msgs::image_encodings::BGR8);
  }
  catch (const cv_bridge::Exception& e)
  {
    NODELET_WARN_THROTTLE(kThrottleS, "yolo_detector: cannot draw on image of encoding '%s' from %s: %s",
                          image_msg->encoding.c_str(), sub_image_.getTopic().c_str(), e.what());
    return;
  }
  drawDetections(canvas->image, detections);
  pub_image_.publish(canvas->toImageMsg());
}

void YoloDetectorNodelet::diagnose(diagnostic_updater::DiagnosticStatusWrapper& status)
{
  std::lock_guard<std::mutex> lock(stats_mutex_);
  if (frames_failed_ > failed_reported_)
  {
    status.mergeSummaryf(diagnostic_msgs::DiagnosticStatus::ERROR,
                         "%lu images could not be processed since the last report",
                         static_cast<unsigned long>(frames_failed_ - failed_reported_));
  }
  else if (frames_dropped_ > dropped_reported_)
  {
    status.mergeSummaryf(diagnostic_msgs::DiagnosticStatus::WARN,
                         "%lu frames dropped since the last report: inference slower than the camera",
                         static_cast<unsigned long>(frames_dropped_ - dropped_reported_));
  }
  dropped_reported_ = frames_dropped_;
  failed_reported_ = frames_failed_;
  status.add("backend", stage_->params().backend);
  status.add("detector", stage_->detector().description());
  status.add("frames received", frames_received_);
  status.add("frames processed", frames_processed_);
  status.add("frames dropped", frames_dropped_);
  status.add("frames failed", frames_failed_);
  status.addf("last inference time [ms]", "%.2f", last_inference_ms_);
  status.addf("mean inference time [ms]", "%.2f",
              frames_processed_ > 0 ? total_inference_ms_ / static_cast<double>(frames_processed_) : 0.0);
}

}  // namespace grid_vision_fusion

PLUGINLIB_EXPORT_CLASS(grid_vision_fusion::YoloDetectorNodelet, nodelet::Nodelet)
