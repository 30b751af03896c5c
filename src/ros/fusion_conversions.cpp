#include "grid_vision_fusion/ros/fusion_conversions.h"

#include <boost/make_shared.hpp>

#include <sstream>
#include <stdexcept>

#include "grid_vision_fusion/fusion/overlay.h"

namespace grid_vision_fusion
{
namespace
{
constexpr double kMarkerLifetimeS = 0.5;
constexpr double kCylinderDiameterM = 1.8;
constexpr double kCylinderHeightM = 1.5;

std_msgs::ColorRGBA toColor(Motion motion)
{
  const cv::Scalar bgr = motionColor(motion);
  std_msgs::ColorRGBA color;
  color.b = static_cast<float>(bgr[0] / 255.0);
  color.g = static_cast<float>(bgr[1] / 255.0);
  color.r = static_cast<float>(bgr[2] / 255.0);
  color.a = 0.8F;
  return color;
}

visualization_msgs::Marker baseMarker(const DetectedObjectArray& objects, const std::string& ns,
                                      std::uint32_t id, int type)
{
  visualization_msgs::Marker marker;
  marker.header = objects.header;
  marker.ns = ns;
  marker.id = static_cast<int>(id);
  marker.type = type;
  marker.action = visualization_msgs::Marker::ADD;
  marker.pose.orientation.w = 1.0;
  marker.lifetime = ros::Duration(kMarkerLifetimeS);
  return marker;
}
}  // namespace

std::vector<Detection> detectionsFromMsg(const Detection2DArray& msg)
{
  std::vector<Detection> detections;
  detections.reserve(msg.detections.size());
  for (const auto& d : msg.detections)
  {
    Detection detection;
    detection.class_id = d.class_id;
    detection.label = d.label;
    detection.score = d.score;
    detection.box = BoundingBox{d.x_min, d.y_min, d.x_max, d.y_max};
    detections.push_back(std::move(detection));
  }
  return detections;
}

std::string checkProjectedGrid(const ProjectedGrid& msg)
{
  const std::size_t n = msg.u.size();
  const std::pair<const char*, std::size_t> sizes[] = {{"v", msg.v.size()},
                                                       {"depth", msg.depth.size()},
                                                       {"x", msg.x.size()},
                                                       {"y", msg.y.size()},
                                                       {"vx", msg.vx.size()},
                                                       {"vy", msg.vy.size()},
                                                       {"p_static", msg.p_static.size()},
                                                       {"p_dynamic", msg.p_dynamic.size()},
                                                       {"state", msg.state.size()}};
  for (const auto& [name, size] : sizes)
  {
    if (size != n)
    {
      std::ostringstream error;
      error << "ProjectedGrid arrays differ in length: u has " << n << " elements, " << name << " has "
            << size;
      return error.str();
    }
  }
  if ((!msg.v_var_x.empty() || !msg.v_var_y.empty()) && (msg.v_var_x.size() != n || msg.v_var_y.size() != n))
  {
    return "ProjectedGrid arrays v_var_x and v_var_y have " + std::to_string(msg.v_var_x.size()) + " and " +
           std::to_string(msg.v_var_y.size()) +
           " elements, expected none (not carried) or as many as u: " + std::to_string(n);
  }
  if (!msg.scans_since_hit.empty() && msg.scans_since_hit.size() != n)
  {
    return "ProjectedGrid array scans_since_hit has " + std::to_string(msg.scans_since_hit.size()) +
           " elements, expected none (not carried) or as many as u: " + std::to_string(n);
  }
  return {};
}

ProjectedPointsView viewOf(const ProjectedGrid& msg)
{
  return pointsViewOf(msg);
}

ImageGround imageGroundOf(const ProjectedGrid& msg)
{
  ImageGround ground;
  for (int r = 0; r < 3; ++r)
  {
    for (int c = 0; c < 4; ++c)
    {
      ground.grid_to_image(r, c) = msg.grid_to_image[static_cast<std::size_t>(4 * r + c)];
    }
  }
  ground.ground_z = msg.ground_z;
  return ground;
}

DetectedObjectArray::Ptr objectsToMsg(const std_msgs::Header& image_header, const std::string& grid_frame_id,
                                      const std::vector<Detection>& detections, const FusionResult& result)
{
  auto msg = boost::make_shared<DetectedObjectArray>();
  msg->header.stamp = image_header.stamp;
  msg->header.frame_id = grid_frame_id;
  msg->image_frame_id = image_header.frame_id;
  if (result.reports.size() != result.objects.size())
  {
    throw std::invalid_argument("objectsToMsg: " + std::to_string(result.reports.size()) + " reports for " +
                                std::to_string(result.objects.size()) +
                                " objects (reportPerFrame() or trackObjects() makes them)");
  }
  msg->objects.reserve(result.objects.size());
  for (std::size_t i = 0; i < result.objects.size(); ++i)
  {
    const FusedObject& object = result.objects[i];
    const ReportedObject& report = result.reports[i];
    const Detection& detection = detections.at(object.detection_index);
    DetectedObject out;
    out.id = report.id;
    out.class_id = report.class_id;
    out.label = report.label;
    out.score = detection.score;
    out.motion = static_cast<std::uint8_t>(report.motion);
    out.p_dynamic = static_cast<float>(report.p_dynamic);
    out.track_state = static_cast<std::uint8_t>(report.track_state);
    out.position_source = static_cast<std::uint8_t>(report.support);
    out.static_points = object.static_points;
    out.dynamic_points = object.dynamic_points;
    out.position.x = report.x;
    out.position.y = report.y;
    out.velocity.x = report.vx;
    out.velocity.y = report.vy;
    out.heading = static_cast<float>(report.heading);
    out.x_min = detection.box.x_min;
    out.y_min = detection.box.y_min;
    out.x_max = detection.box.x_max;
    out.y_max = detection.box.y_max;
    msg->objects.push_back(std::move(out));
  }
  return msg;
}

visualization_msgs::MarkerArray::Ptr objectsToMarkers(const DetectedObjectArray& objects, bool with_ids)
{
  auto markers = boost::make_shared<visualization_msgs::MarkerArray>();
  visualization_msgs::Marker clear;
  clear.header = objects.header;
  clear.action = visualization_msgs::Marker::DELETEALL;
  markers->markers.push_back(clear);
  for (const auto& object : objects.objects)
  {
    const auto motion = static_cast<Motion>(object.motion);
    const bool tentative = object.track_state == DetectedObject::TRACK_TENTATIVE;
    // A new (tentative) track is drawn grey, as an object without a verdict.
    const std_msgs::ColorRGBA color = toColor(tentative ? Motion::kUnknown : motion);

    auto body = baseMarker(objects, "objects", object.id, visualization_msgs::Marker::CYLINDER);
    body.pose.position = object.position;
    body.pose.position.z = kCylinderHeightM / 2.0;
    body.scale.x = body.scale.y = kCylinderDiameterM;
    body.scale.z = kCylinderHeightM;
    body.color = color;
    markers->markers.push_back(body);

    const double speed = std::hypot(object.velocity.x, object.velocity.y);
    if (motion == Motion::kDynamic)
    {
      auto arrow = baseMarker(objects, "velocities", object.id, visualization_msgs::Marker::ARROW);
      geometry_msgs::Point tip = object.position;
      tip.x += object.velocity.x;
      tip.y += object.velocity.y;
      arrow.points = {object.position, tip};
      arrow.points[0].z = arrow.points[1].z = kCylinderHeightM;
      arrow.scale.x = 0.2;  // shaft diameter
      arrow.scale.y = 0.4;  // head diameter
      arrow.scale.z = 0.4;  // head length
      arrow.color = color;
      markers->markers.push_back(arrow);
    }

    auto label = baseMarker(objects, "labels", object.id, visualization_msgs::Marker::TEXT_VIEW_FACING);
    label.pose.position = object.position;
    label.pose.position.z = kCylinderHeightM + 0.8;
    label.scale.z = 0.8;
    label.color = color;
    label.color.a = 1.0F;
    label.text = with_ids ? trackLabel(object.id, motion, object.label, speed)
                          : objectLabel(motion, object.label, speed);
    if (tentative)
    {
      label.text += " (new track)";
    }
    markers->markers.push_back(label);
  }
  return markers;
}

}  // namespace grid_vision_fusion
