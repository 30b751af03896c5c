#include "grid_vision_fusion/offline/detection_bag.h"

#include "grid_vision_fusion/offline/bag_errors.h"

#include <rosbag/bag.h>
#include <rosbag/view.h>

#include <cmath>
#include <map>
#include <stdexcept>

namespace grid_vision_fusion
{
namespace
{
bool finite(const DetectedObject& o)
{
  return std::isfinite(o.x_min) && std::isfinite(o.y_min) && std::isfinite(o.x_max) &&
         std::isfinite(o.y_max) && std::isfinite(o.score) && std::isfinite(o.position.x) &&
         std::isfinite(o.position.y) && std::isfinite(o.velocity.x) && std::isfinite(o.velocity.y) &&
         o.x_max >= o.x_min && o.y_max >= o.y_min;
}

Motion toMotion(std::uint8_t motion)
{
  switch (motion)
  {
    case DetectedObject::MOTION_STATIC:
      return Motion::kStatic;
    case DetectedObject::MOTION_DYNAMIC:
      return Motion::kDynamic;
    default:
      return Motion::kUnknown;
  }
}
}  // namespace

void DetectionBagConfig::validate() const
{
  if (topic.empty())
  {
    throw std::invalid_argument("topic must not be empty");
  }
  if (!(stamp_tolerance_s > 0.0) || !std::isfinite(stamp_tolerance_s))
  {
    throw std::invalid_argument("stamp_tolerance_s must be a finite value > 0, got " +
                                std::to_string(stamp_tolerance_s));
  }
}

EvalObject toEvalObject(const DetectedObject& object, const std::string& frame_name,
                        const Eigen::Isometry3d& velo_from_world, const std::string& label)
{
  EvalObject o;
  o.frame = frame_name;
  o.label = label;
  o.motion = toMotion(object.motion);
  o.box = BoundingBox{object.x_min, object.y_min, object.x_max, object.y_max};
  o.score = object.score;
  o.has_state = true;
  o.track_id = object.id;
  o.p_dynamic = object.p_dynamic;
  o.x = object.position.x;
  o.y = object.position.y;
  o.vx = object.velocity.x;
  o.vy = object.velocity.y;
  o.longitudinal_m = (velo_from_world * Eigen::Vector3d(object.position.x, object.position.y, 0.0)).x();
  return o;
}

namespace
{
/// `object` with its position and velocity moved by `to_from_message` (message frame → another).
DetectedObject inFrame(DetectedObject object, const Eigen::Isometry3d& to_from_message)
{
  const Eigen::Vector3d p = to_from_message * Eigen::Vector3d(object.position.x, object.position.y, 0.0);
  const Eigen::Vector3d v =
      to_from_message.linear() * Eigen::Vector3d(object.velocity.x, object.velocity.y, 0.0);
  object.position.x = p.x();
  object.position.y = p.y();
  object.velocity.x = v.x();
  object.velocity.y = v.y();
  const Eigen::Vector3d heading =
      to_from_message.linear() * Eigen::Vector3d(std::cos(object.heading), std::sin(object.heading), 0.0);
  object.heading = static_cast<float>(std::atan2(heading.y(), heading.x()));
  return object;
}
}  // namespace

namespace
{
/// Opens `bag` at `bag_path` for reading.
void openBag(rosbag::Bag& bag, const std::string& bag_path)
{
  try
  {
    bag.open(bag_path, rosbag::bagmode::Read);
  }
  catch (const rosbag::BagException& e)
  {
    throw std::runtime_error(bagReadError(bag_path, e.what()));
  }
}

/// The error for a bag without a message on `topic`, naming the topics it has.
std::runtime_error noMessageError(const std::string& bag_path, const rosbag::Bag& bag,
                                  const std::string& topic)
{
  std::string topics;
  rosbag::View all(bag);
  for (const rosbag::ConnectionInfo* c : all.getConnections())
  {
    if (topics.find(" " + c->topic + " ") == std::string::npos)
    {
      topics += " " + c->topic + " ";
    }
  }
  return std::runtime_error(
      bag_path + ": no message on topic " + topic +
      (topics.empty() ? std::string(" (the bag is empty)") : " (topics:" + topics + ")"));
}

/// One message's objects for its frame, and how far its stamp lies from the frame's.
struct Kept
{
  double gap = 0.0;
  std::vector<EvalObject> objects;
};

/// What readDetectionBag() reads every message with.
struct DetectionBagReader
{
  const std::string& bag_path;
  const KittiDrive& drive;
  const DetectionBagConfig& config;
  const KittiGroundTruthConfig& labels;
  std::vector<double> times;  ///< the drive's frame times
};

/// The pose of the message's frame in the world at `frame`: the drive's odom pose when the
/// message is in the odometry frame, else the identity (counted when not the world frame).
Eigen::Isometry3d worldFromMessage(const DetectionBagReader& reader, const std::string& frame_id, int frame,
                                   DetectionBagStats& stats)
{
  Eigen::Isometry3d world_from_message = Eigen::Isometry3d::Identity();
  if (frame_id == reader.config.odom_frame && frame_id != reader.config.world_frame)
  {
    try
    {
      world_from_message = reader.drive.worldFromOdom(frame);
    }
    catch (const std::out_of_range& e)
    {
      throw std::runtime_error(reader.bag_path + ": detections in " + reader.config.odom_frame + ", but " +
                               e.what());
    }
  }
  else if (frame_id != reader.config.world_frame)
  {
    ++stats.other_frame;
  }
  return world_from_message;
}

/// The objects of the message `msg` stamped `t` as evaluation objects of `frame`: the finite ones
/// of a class the labels know.
Kept keptObjects(const DetectionBagReader& reader, const DetectedObjectArray& msg, int frame, double t,
                 DetectionBagStats& stats)
{
  const Eigen::Isometry3d world_from_message = worldFromMessage(reader, msg.header.frame_id, frame, stats);
  Kept kept;
  kept.gap = std::abs(reader.times[static_cast<std::size_t>(frame)] - t);
  const std::string frame_name = kittiFrameName(frame);
  const Eigen::Isometry3d velo_from_world = reader.drive.worldFromVelo(frame).inverse();
  for (const DetectedObject& object : msg.objects)
  {
    if (!finite(object))
    {
      ++stats.invalid_objects;
      continue;
    }
    const std::string label = reader.labels.labelOf(object.label);
    if (label.empty())
    {
      ++stats.dropped_labels;
      continue;
    }
    kept.objects.push_back(
        toEvalObject(inFrame(object, world_from_message), frame_name, velo_from_world, label));
    kept.objects.back().time_s = reader.times[static_cast<std::size_t>(frame)];
  }
  return kept;
}

/// Every message of `view` (`total` of them) by the drive frame nearest its stamp; of two for one
/// frame the one nearer in time.
std::map<int, Kept> keptFrames(const DetectionBagReader& reader, rosbag::View& view, std::size_t total,
                               const std::function<void(std::size_t, std::size_t)>& progress,
                               DetectionBagStats& stats)
{
  std::map<int, Kept> by_frame;
  std::size_t read = 0;
  for (const rosbag::MessageInstance& m : view)
  {
    const DetectedObjectArray::ConstPtr msg = m.instantiate<DetectedObjectArray>();
    if (!msg)
    {
      throw std::runtime_error(reader.bag_path + ": topic " + reader.config.topic + " carries " +
                               m.getDataType() + ", not grid_vision_fusion/DetectedObjectArray");
    }
    ++read;
    ++stats.messages;
    if (progress)
    {
      progress(read, total);
    }
    const double t = msg->header.stamp.toSec();
    const int frame = nearestFrame(reader.times, t, reader.config.stamp_tolerance_s);
    if (frame < 0)
    {
      ++stats.unmatched;
      continue;
    }
    Kept kept = keptObjects(reader, *msg, frame, t, stats);
    const auto existing = by_frame.find(frame);
    if (existing != by_frame.end())
    {
      ++stats.duplicates;
      if (existing->second.gap <= kept.gap)
      {
        continue;
      }
    }
    by_frame[frame] = std::move(kept);
  }
  return by_frame;
}
}  // namespace

DetectionBagResult readDetectionBag(const std::string& bag_path, const KittiDrive& drive,
                                    const DetectionBagConfig& config, const KittiGroundTruthConfig& labels,
                                    const std::function<void(std::size_t, std::size_t)>& progress)
{
  config.validate();
  rosbag::Bag bag;
  openBag(bag, bag_path);
  DetectionBagResult result;
  try
  {
    rosbag::View view(bag, rosbag::TopicQuery(config.topic));
    const std::size_t total = view.size();
    if (total == 0)
    {
      throw noMessageError(bag_path, bag, config.topic);
    }
    const DetectionBagReader reader{bag_path, drive, config, labels, drive.frameTimes()};
    std::map<int, Kept> by_frame = keptFrames(reader, view, total, progress, result.stats);
    for (auto& [frame, kept] : by_frame)
    {
      result.frames.insert(frame);
      for (EvalObject& o : kept.objects)
      {
        result.detections.push_back(std::move(o));
      }
    }
  }
  catch (const rosbag::BagException& e)
  {
    throw std::runtime_error(bagReadError(bag_path, e.what()));
  }
  return result;
}

}  // namespace grid_vision_fusion
