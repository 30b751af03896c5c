// Tests of the message <-> core conversions of the fusion (no master needed).
#include <gtest/gtest.h>

#include <stdexcept>

#include <ros/time.h>

#include "grid_vision_fusion/ros/fusion_conversions.h"

namespace grid_vision_fusion
{
namespace
{
ProjectedGrid makeGrid(std::size_t n)
{
  ProjectedGrid grid;
  grid.header.stamp = ros::Time(100, 5);
  grid.header.frame_id = "camera_color_left";
  grid.grid_frame_id = "world";
  for (auto* array :
       {&grid.u, &grid.v, &grid.depth, &grid.x, &grid.y, &grid.vx, &grid.vy, &grid.p_static, &grid.p_dynamic})
  {
    array->assign(n, 1.F);
  }
  grid.state.assign(n, ProjectedGrid::STATIC);
  return grid;
}
}  // namespace

TEST(FusionConversions, CheckProjectedGridNamesTheShortArray)
{
  EXPECT_EQ(checkProjectedGrid(makeGrid(3)), "");
  ProjectedGrid grid = makeGrid(3);
  grid.vy.pop_back();
  const std::string error = checkProjectedGrid(grid);
  EXPECT_NE(error.find("vy has 2"), std::string::npos) << error;
  EXPECT_NE(error.find("u has 3"), std::string::npos) << error;
}

TEST(FusionConversions, ViewBorrowsTheArrays)
{
  ProjectedGrid grid = makeGrid(4);
  ProjectedPointsView view = viewOf(grid);
  EXPECT_EQ(view.size, 4U);
  EXPECT_EQ(view.u, grid.u.data());
  EXPECT_EQ(view.vy, grid.vy.data());
  EXPECT_EQ(view.state, grid.state.data());
  EXPECT_EQ(view.scans_since_hit, nullptr);  // optional, not carried
  grid.scans_since_hit.assign(4, 0);
  view = viewOf(grid);
  EXPECT_EQ(view.scans_since_hit, grid.scans_since_hit.data());
  EXPECT_EQ(view.resolution, 0.0);  // not given
  grid.resolution = 0.2F;
  EXPECT_FLOAT_EQ(static_cast<float>(viewOf(grid).resolution), 0.2F);
}

TEST(FusionConversions, TheCellAgesAreOptionalButNeverShort)
{
  ProjectedGrid grid = makeGrid(3);
  grid.scans_since_hit.assign(3, 1);
  EXPECT_EQ(checkProjectedGrid(grid), "");
  grid.scans_since_hit.pop_back();
  const std::string error = checkProjectedGrid(grid);
  EXPECT_NE(error.find("scans_since_hit has 2"), std::string::npos) << error;
}

TEST(FusionConversions, ObjectsCarryEveryField)
{
  Detection2DArray detections_msg;
  detections_msg.header.stamp = ros::Time(100, 5);
  detections_msg.header.frame_id = "camera_color_left";
  Detection2D d;
  d.class_id = 2;
  d.label = "car";
  d.score = 0.75F;
  d.x_min = 10.F;
  d.y_min = 20.F;
  d.x_max = 30.F;
  d.y_max = 40.F;
  detections_msg.detections = {d, d};
  const std::vector<Detection> detections = detectionsFromMsg(detections_msg);
  ASSERT_EQ(detections.size(), 2U);
  EXPECT_EQ(detections[0].box.y_max, 40.F);

  FusionResult result;
  FusedObject object;
  object.detection_index = 1;
  object.static_points = 1;
  object.dynamic_points = 2;
  result.objects.push_back(object);
  EXPECT_THROW(objectsToMsg(detections_msg.header, "world", detections, result), std::invalid_argument)
      << "an object without its report";
  ReportedObject report;
  report.id = 0;
  report.label = "car";
  report.class_id = 2;
  report.motion = Motion::kDynamic;
  report.x = 5.0;
  report.y = -1.0;
  report.vx = 3.0;
  report.vy = 4.0;
  report.heading = 0.9272952;
  report.p_dynamic = 0.875;
  report.track_state = TrackState::kConfirmed;
  result.reports.push_back(report);

  const DetectedObjectArray::Ptr msg = objectsToMsg(detections_msg.header, "world", detections, result);
  EXPECT_EQ(msg->header.stamp, ros::Time(100, 5));
  EXPECT_EQ(msg->header.frame_id, "world");
  EXPECT_EQ(msg->image_frame_id, "camera_color_left");
  ASSERT_EQ(msg->objects.size(), 1U);
  const DetectedObject& o = msg->objects[0];
  EXPECT_EQ(o.id, 0U);
  EXPECT_EQ(o.class_id, 2U);
  EXPECT_EQ(o.label, "car");
  EXPECT_FLOAT_EQ(o.score, 0.75F);
  EXPECT_EQ(o.motion, DetectedObject::MOTION_DYNAMIC);
  EXPECT_FLOAT_EQ(o.p_dynamic, 0.875F);
  EXPECT_EQ(o.track_state, DetectedObject::TRACK_CONFIRMED);
  EXPECT_EQ(o.static_points, 1U);
  EXPECT_EQ(o.dynamic_points, 2U);
  EXPECT_DOUBLE_EQ(o.position.x, 5.0);
  EXPECT_DOUBLE_EQ(o.position.y, -1.0);
  EXPECT_DOUBLE_EQ(o.position.z, 0.0);
  EXPECT_DOUBLE_EQ(o.velocity.x, 3.0);
  EXPECT_DOUBLE_EQ(o.velocity.y, 4.0);
  EXPECT_FLOAT_EQ(o.heading, 0.9272952F);
  EXPECT_FLOAT_EQ(o.x_min, 10.F);
  EXPECT_FLOAT_EQ(o.y_max, 40.F);

  const visualization_msgs::MarkerArray::Ptr markers = objectsToMarkers(*msg, false);
  // DELETEALL, cylinder, arrow, text.
  ASSERT_EQ(markers->markers.size(), 4U);
  EXPECT_EQ(markers->markers[0].action, visualization_msgs::Marker::DELETEALL);
  EXPECT_EQ(markers->markers[1].type, visualization_msgs::Marker::CYLINDER);
  EXPECT_DOUBLE_EQ(markers->markers[1].pose.position.x, 5.0);
  EXPECT_EQ(markers->markers[1].header.frame_id, "world");
  EXPECT_EQ(markers->markers[2].type, visualization_msgs::Marker::ARROW);
  ASSERT_EQ(markers->markers[2].points.size(), 2U);
  EXPECT_DOUBLE_EQ(markers->markers[2].points[1].x - markers->markers[2].points[0].x, 3.0);
  EXPECT_EQ(markers->markers[3].type, visualization_msgs::Marker::TEXT_VIEW_FACING);
  EXPECT_EQ(markers->markers[3].text, "dynamic car 5.0 m/s");

  // A tentative track: grey, labelled as new.
  msg->objects[0].track_state = DetectedObject::TRACK_TENTATIVE;
  const visualization_msgs::MarkerArray::Ptr tentative = objectsToMarkers(*msg, true);
  ASSERT_EQ(tentative->markers.size(), 4U);
  EXPECT_EQ(tentative->markers[3].text, "#0 dynamic car 5.0 m/s (new track)");
  EXPECT_FLOAT_EQ(tentative->markers[1].color.g, tentative->markers[1].color.r) << "grey, not green";
}

TEST(FusionConversions, StaticObjectHasNoArrow)
{
  DetectedObjectArray objects;
  DetectedObject o;
  o.label = "van";
  o.motion = DetectedObject::MOTION_STATIC;
  objects.objects.push_back(o);
  const auto markers = objectsToMarkers(objects, false);
  ASSERT_EQ(markers->markers.size(), 3U);
  EXPECT_EQ(markers->markers[2].text, "static van");
}

}  // namespace grid_vision_fusion
