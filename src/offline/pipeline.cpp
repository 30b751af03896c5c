#include "grid_vision_fusion/offline/pipeline.h"

#include <rosbag/view.h>
#include <sys/resource.h>
#include <tf2/exceptions.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <deque>
#include <exception>
#include <fstream>
#include <mutex>
#include <thread>

#include "grid_vision_fusion/offline/bag_errors.h"
#include "grid_vision_fusion/ros/detector_conversions.h"
#include "grid_vision_fusion/ros/grid_conversions.h"
#include "grid_vision_fusion/ros/projection_conversions.h"

namespace grid_vision_fusion
{
namespace
{
constexpr std::size_t kMaxWarnings = 20;

double elapsedMs(const std::chrono::steady_clock::time_point& start)
{
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
}
}  // namespace

PipelineConfig pipelineConfigFromParams(const ParamSource& grid, const ParamSource& detector,
                                        const ParamSource& projection, const ParamSource& fusion,
                                        std::vector<std::string>* unknown)
{
  PipelineConfig config;
  std::vector<std::string> node_unknown;
  auto collect = [&]
  {
    if (unknown)
    {
      unknown->insert(unknown->end(), node_unknown.begin(), node_unknown.end());
    }
  };
  config.grid = DynamicGridParams::fromParams(grid, &node_unknown);
  collect();
  config.detector = DetectorParams::fromParams(detector, &node_unknown);
  collect();
  config.projection = GridProjectionParams::fromParams(projection, &node_unknown);
  collect();
  config.fusion = FusionParams::fromParams(fusion, &node_unknown);
  collect();
  return config;
}

Pipeline::Pipeline(const PipelineConfig& config, PipelineOutputs outputs)
    : config_(config), outputs_(std::move(outputs)), tf_(ros::Duration(tf2::BufferCore::DEFAULT_CACHE_TIME))
{
  if (!(config_.max_tf_wait >= 0.0))
  {
    throw std::invalid_argument("max_tf_wait must be >= 0 s");
  }
  if (config_.fusion.queue_size < 1)
  {
    throw std::invalid_argument("fusion queue_size must be >= 1");
  }
  grid_ = std::make_unique<GridStage>(config_.grid);
  detector_ = std::make_unique<DetectorStage>(config_.detector);
  projection_ = std::make_unique<ProjectionStage>(config_.projection);
  fusion_ = std::make_unique<FusionStage>(config_.fusion);
}

Pipeline::~Pipeline() = default;

void Pipeline::warn(const std::string& what)
{
  if (stats_.warnings.size() < kMaxWarnings &&
      std::find(stats_.warnings.begin(), stats_.warnings.end(), what) == stats_.warnings.end())
  {
    stats_.warnings.push_back(what);
  }
}

void Pipeline::addTf(const tf2_msgs::TFMessage& msg, bool is_static)
{
  for (const auto& transform : msg.transforms)
  {
    try
    {
      tf_.setTransform(transform, is_static ? "bag /tf_static" : "bag /tf", is_static);
    }
    catch (const std::exception& e)
    {
      warn(std::string("transform ignored: ") + e.what());
    }
    if (!is_static && transform.header.stamp > latest_tf_stamp_)
    {
      latest_tf_stamp_ = transform.header.stamp;
    }
  }
}

void Pipeline::enqueue(Pending pending)
{
  pending.order = arrivals_++;
  const auto before = [](const Pending& a, const Pending& b)
  {
    if (a.stamp != b.stamp)
    {
      return a.stamp < b.stamp;
    }
    if (a.kind != b.kind)
    {
      return a.kind < b.kind;
    }
    return a.order < b.order;
  };
  queue_.insert(std::upper_bound(queue_.begin(), queue_.end(), pending, before), std::move(pending));
}

void Pipeline::addCloud(const sensor_msgs::PointCloud2::ConstPtr& msg)
{
  ++stats_.clouds;
  Pending p;
  p.stamp = msg->header.stamp;
  p.kind = Kind::kCloud;
  p.cloud = msg;
  enqueue(std::move(p));
}

void Pipeline::addImage(const sensor_msgs::Image::ConstPtr& msg)
{
  ++stats_.images;
  Pending p;
  p.stamp = msg->header.stamp;
  p.kind = Kind::kImage;
  p.image = msg;
  enqueue(std::move(p));
}

void Pipeline::addCameraInfo(const sensor_msgs::CameraInfo::ConstPtr& msg)
{
  ++stats_.camera_infos;
  Pending p;
  p.stamp = msg->header.stamp;
  p.kind = Kind::kCameraInfo;
  p.info = msg;
  enqueue(std::move(p));
}

void Pipeline::advanceTo(const ros::Time& bag_time)
{
  if (bag_time > bag_time_)
  {
    bag_time_ = bag_time;
  }
  release(false);
}

void Pipeline::finish()
{
  release(true);
  collectDetection();
}

bool Pipeline::tfReady(const Pending& p) const
{
  const std::string& fixed = config_.grid.fixed_frame;
  switch (p.kind)
  {
    case Kind::kCloud:
      return tf_.canTransform(fixed, p.cloud->header.frame_id, p.stamp, nullptr);
    case Kind::kCameraInfo:
    {
      const std::string& ground = config_.projection.ground_frame;
      const std::string grid_frame = latest_grid_ ? latest_grid_->header.frame_id : fixed;
      return tf_.canTransform(p.info->header.frame_id, grid_frame, p.stamp, nullptr) &&
             (ground.empty() || tf_.canTransform(grid_frame, ground, p.stamp, nullptr));
    }
    case Kind::kImage:
    default:
      return true;
  }
}

void Pipeline::release(bool everything)
{
  while (!queue_.empty())
  {
    const Pending& head = queue_.front();
    if (!everything)
    {
      // Every message stamped up to the head's stamp has been read once the bag is past it.
      if (!(bag_time_ > head.stamp))
      {
        return;
      }
      if (!tfReady(head) && (bag_time_ - head.stamp).toSec() < config_.max_tf_wait)
      {
        return;
      }
    }
    const Pending pending = std::move(queue_.front());
    queue_.pop_front();
    process(pending);
  }
}

void Pipeline::process(const Pending& pending)
{
  switch (pending.kind)
  {
    case Kind::kCloud:
      processCloud(*pending.cloud);
      break;
    case Kind::kImage:
      processImage(pending.image);
      break;
    case Kind::kCameraInfo:
      processCameraInfo(*pending.info);
      break;
  }
}

void Pipeline::processCloud(const sensor_msgs::PointCloud2& msg)
{
  const auto start = std::chrono::steady_clock::now();
  DynamicGridCycle cycle;
  try
  {
    cycle = grid_->update(msg, tf_);
  }
  catch (const UnusableMessage& e)
  {
    ++stats_.grid_drops;
    warn("dynamic_grid: cloud of frame '" + msg.header.frame_id + "' unusable: " + e.what());
    return;
  }
  catch (const tf2::TransformException& e)
  {
    ++stats_.grid_drops;
    warn("dynamic_grid: scan dropped, no tf " + config_.grid.fixed_frame + " <- " + msg.header.frame_id +
         ": " + e.what());
    return;
  }
  if (cycle.reset)
  {
    ++stats_.grid_resets;
    warn("dynamic_grid: grid reset: " + cycle.reset_reason);
  }
  DynamicGrid::ConstPtr grid = grid_->gridMsg();
  const std::string grid_error = checkDynamicGrid(*grid);
  if (!grid_error.empty())
  {
    ++stats_.grid_drops;
    warn("grid_projection: grid dropped: " + grid_error);
  }
  else
  {
    latest_grid_ = grid;
  }
  ++stats_.grids;
  stats_.grid_ms.push_back(elapsedMs(start));
  if (outputs_.grid)
  {
    outputs_.grid(grid);
  }
}

void Pipeline::processImage(const sensor_msgs::Image::ConstPtr& msg)
{
  collectDetection();  // one detection at a time: the detector is not thread-safe
  std::int64_t frame_index = -1;
  try
  {
    frame_index = detector_->frameIndex(*msg);
  }
  catch (const std::exception& e)
  {
    ++stats_.detector_drops;
    warn(std::string("yolo_detector: image not processed: ") + e.what());
    return;
  }
  auto detect = [this, msg, frame_index]
  {
    const auto start = std::chrono::steady_clock::now();
    std::vector<Detection> detections = detector_->detect(msg, frame_index);
    return std::make_pair(std::move(detections), elapsedMs(start));
  };
  detecting_ = msg;
  detection_ = std::async(config_.overlap_detector ? std::launch::async : std::launch::deferred, detect);
}

void Pipeline::collectDetection()
{
  if (!detecting_)
  {
    return;
  }
  const sensor_msgs::Image::ConstPtr msg = std::move(detecting_);
  detecting_.reset();
  std::pair<std::vector<Detection>, double> result;
  try
  {
    result = detection_.get();
  }
  catch (const std::exception& e)
  {
    ++stats_.detector_drops;
    warn(std::string("yolo_detector: image not processed: ") + e.what());
    return;
  }
  Detection2DArray::ConstPtr out = detectionsToMsg(msg->header, msg->width, msg->height, result.first);
  ++stats_.detections;
  stats_.detector_ms.push_back(result.second);
  if (outputs_.detections)
  {
    outputs_.detections(out);
  }
  detections_[out->header.stamp] = out;
  tryFuse(out->header.stamp);
}

void Pipeline::processCameraInfo(const sensor_msgs::CameraInfo& msg)
{
  const auto start = std::chrono::steady_clock::now();
  if (!latest_grid_)
  {
    ++stats_.projection_drops;
    warn("grid_projection: camera_info before any grid");
    return;
  }
  ProjectedGrid::ConstPtr projected;
  ProjectionNotes notes;
  try
  {
    projected = projection_->project(*latest_grid_, msg, tf_, &notes);
  }
  catch (const ProjectionSkipped& e)
  {
    ++stats_.projection_drops;
    warn(std::string("grid_projection: nothing projected: ") + e.what());
    return;
  }
  if (!notes.cells_left_out.empty())
  {
    ++stats_.projections_without_cells;
    warn("grid_projection: projected without cells: " + notes.cells_left_out);
  }
  ++stats_.projections;
  stats_.projection_ms.push_back(elapsedMs(start));
  if (outputs_.projected_grid)
  {
    outputs_.projected_grid(projected);
  }
  projections_[projected->header.stamp] = projected;
  tryFuse(projected->header.stamp);
}

void Pipeline::tryFuse(const ros::Time& stamp)
{
  const auto detections = detections_.find(stamp);
  const auto projection = projections_.find(stamp);
  if (detections != detections_.end() && projection != projections_.end())
  {
    const auto start = std::chrono::steady_clock::now();
    try
    {
      FusedPair pair = fusion_->fuse(*detections->second, *projection->second);
      ++stats_.objects;
      stats_.fusion_ms.push_back(elapsedMs(start));
      if (outputs_.objects)
      {
        outputs_.objects(pair.objects);
      }
    }
    catch (const std::invalid_argument& e)
    {
      ++stats_.fusion_drops;
      warn(std::string("fusion: pair dropped: ") + e.what());
    }
    detections_.erase(detections);
    projections_.erase(projection);
  }
  // A synchroniser queue: the oldest unmatched message goes when the queue is full.
  const auto size = static_cast<std::size_t>(config_.fusion.queue_size);
  while (detections_.size() > size)
  {
    detections_.erase(detections_.begin());
    ++stats_.fusion_drops;
  }
  while (projections_.size() > size)
  {
    projections_.erase(projections_.begin());
    ++stats_.fusion_drops;
  }
}

namespace
{
BagRunSummary runPipelineOnBagUnchecked(Pipeline& pipeline, const std::string& input_bag,
                                        const PipelineTopics& topics,
                                        const std::function<void(std::size_t, std::size_t)>& progress);
}  // namespace

BagRunSummary runPipelineOnBag(Pipeline& pipeline, const std::string& input_bag, const PipelineTopics& topics,
                               const std::function<void(std::size_t, std::size_t)>& progress)
{
  try
  {
    return runPipelineOnBagUnchecked(pipeline, input_bag, topics, progress);
  }
  catch (const rosbag::BagException& e)
  {
    throw std::runtime_error(bagReadError(input_bag, e.what()));
  }
}

namespace
{
/// One message of the input bag, deserialized by the reader thread.
struct BagMessage
{
  std::string topic;
  std::string datatype;
  ros::Time time;
  tf2_msgs::TFMessage::ConstPtr tf;
  sensor_msgs::PointCloud2::ConstPtr cloud;
  sensor_msgs::Image::ConstPtr image;
  sensor_msgs::CameraInfo::ConstPtr info;
};

/// Reads and deserializes the bag's messages on its own thread, a few ahead of the pipeline, so
/// that reading overlaps the stages (the grid does not keep both cores busy all the time). The
/// messages come out in bag order; an exception of the reader (a truncated bag) is rethrown by
/// next().
class BagReader
{
public:
  BagReader(rosbag::View& view, const PipelineTopics& topics)
      : thread_([this, &view, &topics] { read(view, topics); })
  {
  }
  ~BagReader()
  {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      stop_ = true;
    }
    changed_.notify_all();
    thread_.join();
  }
  BagReader(const BagReader&) = delete;
  BagReader& operator=(const BagReader&) = delete;

  /// The next message; false at the end of the bag. @throws what the reader threw.
  bool next(BagMessage& message)
  {
    std::unique_lock<std::mutex> lock(mutex_);
    changed_.wait(lock, [this] { return !queue_.empty() || done_; });
    if (queue_.empty())
    {
      if (error_)
      {
        std::rethrow_exception(error_);
      }
      return false;
    }
    message = std::move(queue_.front());
    queue_.pop_front();
    changed_.notify_all();
    return true;
  }

private:
  static constexpr std::size_t kAhead = 8;  ///< messages read ahead (about two frames)

  void read(rosbag::View& view, const PipelineTopics& topics)
  {
    try
    {
      for (const rosbag::MessageInstance& m : view)
      {
        BagMessage message;
        message.topic = m.getTopic();
        message.datatype = m.getDataType();
        message.time = m.getTime();
        if (message.topic == topics.tf || message.topic == topics.tf_static)
        {
          message.tf = m.instantiate<tf2_msgs::TFMessage>();
        }
        else if (message.topic == topics.points)
        {
          message.cloud = m.instantiate<sensor_msgs::PointCloud2>();
        }
        else if (message.topic == topics.image)
        {
          message.image = m.instantiate<sensor_msgs::Image>();
        }
        else if (message.topic == topics.camera_info)
        {
          message.info = m.instantiate<sensor_msgs::CameraInfo>();
        }
        std::unique_lock<std::mutex> lock(mutex_);
        changed_.wait(lock, [this] { return queue_.size() < kAhead || stop_; });
        if (stop_)
        {
          break;
        }
        queue_.push_back(std::move(message));
        changed_.notify_all();
      }
    }
    catch (...)
    {
      std::lock_guard<std::mutex> lock(mutex_);
      error_ = std::current_exception();
    }
    std::lock_guard<std::mutex> lock(mutex_);
    done_ = true;
    changed_.notify_all();
  }

  std::mutex mutex_;
  std::condition_variable changed_;
  std::deque<BagMessage> queue_;
  bool stop_ = false;
  bool done_ = false;
  std::exception_ptr error_;
  std::thread thread_;  ///< last: started once the members above exist
};

BagRunSummary runPipelineOnBagUnchecked(Pipeline& pipeline, const std::string& input_bag,
                                        const PipelineTopics& topics,
                                        const std::function<void(std::size_t, std::size_t)>& progress)
{
  const auto start = std::chrono::steady_clock::now();
  BagRunSummary summary;
  rosbag::Bag bag(input_bag, rosbag::bagmode::Read);
  const std::vector<std::string> wanted{topics.points, topics.image, topics.camera_info, topics.tf,
                                        topics.tf_static};
  rosbag::View view(bag, rosbag::TopicQuery(wanted));
  const std::size_t total = view.size();
  if (total == 0)
  {
    throw std::runtime_error("bag " + input_bag + " has none of the topics " + topics.points + ", " +
                             topics.image + ", " + topics.camera_info + ", " + topics.tf + ", " +
                             topics.tf_static);
  }
  ros::Time first, last;
  BagReader reader(view, topics);
  BagMessage m;
  while (reader.next(m))
  {
    // The reader instantiated the message of the type its topic needs; the view holds only the
    // pipeline's topics, so none instantiated means a message of another type there.
    if (m.tf)
    {
      pipeline.addTf(*m.tf, m.topic == topics.tf_static);
    }
    else if (m.cloud)
    {
      pipeline.addCloud(m.cloud);
    }
    else if (m.image)
    {
      pipeline.addImage(m.image);
      ++summary.frames;
    }
    else if (m.info)
    {
      pipeline.addCameraInfo(m.info);
    }
    else
    {
      throw std::runtime_error("topic " + m.topic + " of " + input_bag + " holds " + m.datatype +
                               " messages, not the type run_pipeline expects there");
    }
    if (summary.messages_read == 0)
    {
      first = m.time;
    }
    last = m.time;
    ++summary.messages_read;
    pipeline.advanceTo(m.time);
    if (m.topic == topics.image)
    {
      summary.rss_mb.push_back(residentMemoryMiB());
    }
    if (progress)
    {
      progress(summary.messages_read, total);
    }
  }
  pipeline.finish();
  summary.bag_duration_s = (last - first).toSec();
  summary.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return summary;
}
}  // namespace

double residentMemoryMiB()
{
  std::ifstream statm("/proc/self/statm");
  std::size_t size = 0, resident = 0;
  if (!(statm >> size >> resident))
  {
    return 0.0;
  }
  return static_cast<double>(resident) * static_cast<double>(sysconf(_SC_PAGESIZE)) / (1024.0 * 1024.0);
}

double peakResidentMemoryMiB()
{
  rusage usage{};
  if (getrusage(RUSAGE_SELF, &usage) != 0)
  {
    return 0.0;
  }
  return static_cast<double>(usage.ru_maxrss) / 1024.0;  // ru_maxrss is in KiB on Linux
}

}  // namespace grid_vision_fusion
