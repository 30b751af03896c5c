// rostest (issue 13): the bad-input battery. The four nodelets run in one manager
// (bad_input.test); each case publishes a bad message to one of them, waits for the documented
// error or warning on /rosout (from the manager, naming the nodelet), checks that the manager
// still answers its list service with all four nodelets, then publishes good messages and waits
// for the normal output of one of them, so that no bad input leaves state stuck behind.
//
// The nodelets throttle their messages per call site (5 s): the cases are ordered so that
// consecutive ones hit different call sites, and a case whose site logged less than a throttle
// period ago first waits for that period to end.
#include <gtest/gtest.h>

#include <nodelet/NodeletList.h>
#include <nodelet/NodeletLoad.h>
#include <ros/ros.h>
#include <rosgraph_msgs/Log.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>
#include <sensor_msgs/PointCloud2.h>
#include <sensor_msgs/image_encodings.h>
#include <tf2_ros/static_transform_broadcaster.h>
#include <tf2_ros/transform_broadcaster.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <map>
#include <memory>
#include <set>

#include "../detection/tiny_darknet.h"
#include "grid_vision_fusion/DetectedObjectArray.h"
#include "grid_vision_fusion/Detection2DArray.h"
#include "grid_vision_fusion/DynamicGrid.h"
#include "grid_vision_fusion/ProjectedGrid.h"
#include "wait_for.h"

namespace grid_vision_fusion
{
namespace
{
using test::waitFor;

constexpr double kThrottleS = 5.0;  // the nodelets' throttle period (kThrottleS in src/nodelets)
constexpr double kLogTimeoutS = 10.0;
constexpr double kOutputTimeoutS = 20.0;
const char* const kNodelets[] = {"/dynamic_grid", "/yolo_detector", "/grid_projection", "/fusion"};
constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

test::TinyDarknetFiles g_model;

// --- messages ------------------------------------------------------------------------------------

/// A cloud of `n` float32 x, y, z points (point_step 16) on a 10 m circle around the sensor.
sensor_msgs::PointCloud2::Ptr makeCloud(std::size_t n, const ros::Time& stamp, const std::string& frame)
{
  auto cloud = boost::make_shared<sensor_msgs::PointCloud2>();
  cloud->header.stamp = stamp;
  cloud->header.frame_id = frame;
  cloud->height = 1;
  cloud->width = static_cast<std::uint32_t>(n);
  const char* names[] = {"x", "y", "z"};
  for (std::uint32_t k = 0; k < 3; ++k)
  {
    sensor_msgs::PointField field;
    field.name = names[k];
    field.offset = 4 * k;
    field.datatype = sensor_msgs::PointField::FLOAT32;
    field.count = 1;
    cloud->fields.push_back(field);
  }
  cloud->point_step = 16;
  cloud->row_step = static_cast<std::uint32_t>(16 * n);
  cloud->is_dense = true;
  cloud->data.resize(16 * n);
  for (std::size_t i = 0; i < n; ++i)
  {
    const double angle = 2.0 * M_PI * static_cast<double>(i % 720) / 720.0;
    const float xyz[3] = {static_cast<float>(10.0 * std::cos(angle)),
                          static_cast<float>(10.0 * std::sin(angle)),
                          -1.0F + 0.5F * static_cast<float>(i % 3)};
    std::memcpy(&cloud->data[16 * i], xyz, sizeof(xyz));
  }
  return cloud;
}

/// A 64 × 32 rgb8 image, black but for a red 4×4 block (the tiny model's car).
sensor_msgs::Image::Ptr makeImage(const ros::Time& stamp)
{
  auto image = boost::make_shared<sensor_msgs::Image>();
  image->header.stamp = stamp;
  image->header.frame_id = "camera_optical";
  image->width = 64;
  image->height = 32;
  image->encoding = sensor_msgs::image_encodings::RGB8;
  image->step = 64 * 3;
  image->data.assign(image->step * image->height, 0);
  for (std::size_t y = 8; y < 12; ++y)
  {
    for (std::size_t x = 20; x < 24; ++x)
    {
      image->data[y * image->step + x * 3] = 255;
    }
  }
  return image;
}

/// A 10 × 10 grid of 0.5 m cells 5 m ahead of the camera, all static occupied.
DynamicGrid::Ptr makeGrid(const ros::Time& stamp, const std::string& frame = "odom")
{
  auto grid = boost::make_shared<DynamicGrid>();
  grid->header.stamp = stamp;
  grid->header.frame_id = frame;
  grid->info.resolution = 0.5F;
  grid->info.width = 10;
  grid->info.height = 10;
  grid->info.origin.position.x = 5.0;
  grid->info.origin.position.y = -2.5;
  grid->info.origin.orientation.w = 1.0;
  const std::size_t cells = 100;
  grid->p_static.assign(cells, 0.9F);
  grid->p_dynamic.assign(cells, 0.0F);
  grid->p_free.assign(cells, 0.05F);
  grid->p_unknown.assign(cells, 0.05F);
  grid->vx.assign(cells, 0.0F);
  grid->vy.assign(cells, 0.0F);
  grid->v_var_x.assign(cells, 1.0F);
  grid->v_var_y.assign(cells, 1.0F);
  return grid;
}

/// camera_info of a 64 × 32 pinhole camera (f = 50 px) in `frame`.
sensor_msgs::CameraInfo::Ptr makeInfo(const ros::Time& stamp, const std::string& frame = "camera_optical")
{
  auto info = boost::make_shared<sensor_msgs::CameraInfo>();
  info->header.stamp = stamp;
  info->header.frame_id = frame;
  info->width = 64;
  info->height = 32;
  info->P = {50.0, 0.0, 32.0, 0.0, 0.0, 50.0, 16.0, 0.0, 0.0, 0.0, 1.0, 0.0};
  return info;
}

/// One car box in a 64 × 32 image.
Detection2DArray::Ptr makeDetections(const ros::Time& stamp, std::size_t count = 1)
{
  auto msg = boost::make_shared<Detection2DArray>();
  msg->header.stamp = stamp;
  msg->header.frame_id = "camera_optical";
  msg->image_width = 64;
  msg->image_height = 32;
  Detection2D d;
  d.class_id = 0;
  d.label = "car";
  d.score = 0.9F;
  d.x_min = 10.0F;
  d.y_min = 10.0F;
  d.x_max = 30.0F;
  d.y_max = 30.0F;
  msg->detections.assign(count, d);
  return msg;
}

/// Three static points inside the box of makeDetections(), at the bottom edge.
ProjectedGrid::Ptr makeProjected(const ros::Time& stamp)
{
  auto msg = boost::make_shared<ProjectedGrid>();
  msg->header.stamp = stamp;
  msg->header.frame_id = "camera_optical";
  msg->grid_stamp = stamp;
  msg->grid_frame_id = "odom";
  msg->image_width = 64;
  msg->image_height = 32;
  for (int i = 0; i < 3; ++i)
  {
    msg->u.push_back(15.0F + 5.0F * static_cast<float>(i));
    msg->v.push_back(29.0F);
    msg->depth.push_back(8.0F);
    msg->x.push_back(8.0F);
    msg->y.push_back(0.5F * static_cast<float>(i));
    msg->vx.push_back(0.0F);
    msg->vy.push_back(0.0F);
    msg->p_static.push_back(0.9F);
    msg->p_dynamic.push_back(0.0F);
    msg->state.push_back(ProjectedGrid::STATIC);
  }
  return msg;
}

/// odom -> `child`, `z` m above the origin; an optical frame looks along +x (x right = -y,
/// y down = -z, z forward = +x).
geometry_msgs::TransformStamped transform(const std::string& child, const ros::Time& stamp, double z,
                                          bool optical)
{
  geometry_msgs::TransformStamped t;
  t.header.stamp = stamp;
  t.header.frame_id = "odom";
  t.child_frame_id = child;
  t.transform.translation.z = z;
  if (optical)
  {
    t.transform.rotation.x = -0.5;
    t.transform.rotation.y = 0.5;
    t.transform.rotation.z = -0.5;
    t.transform.rotation.w = 0.5;
  }
  else
  {
    t.transform.rotation.w = 1.0;
  }
  return t;
}

/// The tf of `child` around `stamp`, for a tf that arrives after the message of that stamp.
std::vector<geometry_msgs::TransformStamped> lateTransforms(const std::string& child, const ros::Time& stamp,
                                                            double z, bool optical)
{
  std::vector<geometry_msgs::TransformStamped> transforms;
  for (double dt : {-0.1, 0.0, 0.1})
  {
    transforms.push_back(transform(child, stamp + ros::Duration(dt), z, optical));
  }
  return transforms;
}

// --- the bench: publishers of the inputs, subscribers of the outputs and of /rosout ---------------

class Bench
{
public:
  Bench()
  {
    pub_points_ = nh_.advertise<sensor_msgs::PointCloud2>("/bad/points", 10);
    pub_image_ = nh_.advertise<sensor_msgs::Image>("/bad/image", 10);
    pub_grid_ = nh_.advertise<DynamicGrid>("/bad/grid_in", 10);
    pub_info_ = nh_.advertise<sensor_msgs::CameraInfo>("/bad/camera_info", 10);
    pub_detections_ = nh_.advertise<Detection2DArray>("/bad/detections_in", 10);
    pub_projection_image_ = nh_.advertise<sensor_msgs::Image>("/bad/projection_image", 10);
    pub_fusion_image_ = nh_.advertise<sensor_msgs::Image>("/bad/fusion_image", 10);
    pub_projected_ = nh_.advertise<ProjectedGrid>("/bad/projected_grid_in", 10);
    sub_rosout_ = nh_.subscribe<rosgraph_msgs::Log>(
        "/rosout", 1000, [this](const rosgraph_msgs::Log::ConstPtr& m) { log_.push_back(m); });
    sub_grid_ = nh_.subscribe<DynamicGrid>("/bad/grid", 5,
                                           [this](const DynamicGrid::ConstPtr& m)
                                           { outputs_["dynamic_grid"].insert(m->header.stamp); });
    sub_detections_ = nh_.subscribe<Detection2DArray>("/bad/detections", 5,
                                                      [this](const Detection2DArray::ConstPtr& m)
                                                      { outputs_["yolo_detector"].insert(m->header.stamp); });
    sub_projected_ = nh_.subscribe<ProjectedGrid>("/bad/projected_grid", 5,
                                                  [this](const ProjectedGrid::ConstPtr& m)
                                                  { outputs_["grid_projection"].insert(m->header.stamp); });
    // The overlays are subscribed so that the nodelets take images (they are lazy).
    sub_overlays_[0] = nh_.subscribe<sensor_msgs::Image>(
        "/bad/projected_grid/image", 1, [this](const sensor_msgs::Image::ConstPtr&) { ++overlays_; });
    sub_overlays_[1] = nh_.subscribe<sensor_msgs::Image>(
        "/bad/objects/image", 1, [this](const sensor_msgs::Image::ConstPtr&) { ++overlays_; });
    sub_objects_ = nh_.subscribe<DetectedObjectArray>("/bad/objects", 5,
                                                      [this](const DetectedObjectArray::ConstPtr& m)
                                                      { outputs_["fusion"].insert(m->header.stamp); });
  }

  /// Whether every input has its nodelet subscribed (the nodelets are lazy).
  bool connected() const
  {
    return pub_points_.getNumSubscribers() > 0 && pub_image_.getNumSubscribers() > 0 &&
           pub_grid_.getNumSubscribers() > 0 && pub_info_.getNumSubscribers() > 0 &&
           pub_detections_.getNumSubscribers() > 0 && pub_projected_.getNumSubscribers() > 0 &&
           pub_projection_image_.getNumSubscribers() > 0 && pub_fusion_image_.getNumSubscribers() > 0 &&
           sub_rosout_.getNumPublishers() >= 2;  // the manager's and this node's own
  }

  /// The next stamp of the input of `nodelet` (0.1 s apart, as a 10 Hz sensor).
  ros::Time next(const std::string& nodelet)
  {
    auto [it, inserted] = clocks_.emplace(nodelet, ros::Time(1000.0));
    it->second += ros::Duration(0.1);
    return it->second;
  }
  void setClock(const std::string& nodelet, const ros::Time& stamp) { clocks_[nodelet] = stamp; }
  /// A stamp 30 s before the nodelet's clock (time going backwards, a bag loop), from which its
  /// clock goes on; the case expects the nodelet's output for it.
  ros::Time jumpBack(const std::string& nodelet)
  {
    const ros::Time stamp = next(nodelet) - ros::Duration(30.0);
    setClock(nodelet, stamp);
    bad_outputs_.insert(stamp);
    return stamp;
  }

  /// Whether the manager logged (WARN or worse) a line containing `text`.
  bool logged(const std::string& text) const
  {
    return std::any_of(log_.begin(), log_.end(),
                       [&](const rosgraph_msgs::Log::ConstPtr& m)
                       {
                         return m->name == "/manager" && m->level >= rosgraph_msgs::Log::WARN &&
                                m->msg.find(text) != std::string::npos;
                       });
  }
  std::string logText() const
  {
    std::string text;
    for (const auto& m : log_)
    {
      if (m->name == "/manager" && m->level >= rosgraph_msgs::Log::WARN)
      {
        text += "  " + m->msg + "\n";
      }
    }
    return text;
  }

  bool output(const std::string& nodelet, const ros::Time& stamp) const
  {
    const auto it = outputs_.find(nodelet);
    return it != outputs_.end() && it->second.count(stamp) > 0;
  }

  /// Publishes the good input of `nodelet` with the next stamp; returns that stamp.
  ros::Time publishGood(const std::string& nodelet)
  {
    const ros::Time stamp = next(nodelet);
    if (nodelet == "dynamic_grid")
    {
      pub_points_.publish(makeCloud(720, stamp, "velo_link"));
    }
    else if (nodelet == "yolo_detector")
    {
      pub_image_.publish(makeImage(stamp));
    }
    else if (nodelet == "grid_projection")
    {
      pub_grid_.publish(makeGrid(stamp));
      pub_info_.publish(makeInfo(stamp));
    }
    else
    {
      pub_detections_.publish(makeDetections(stamp));
      pub_projected_.publish(makeProjected(stamp));
    }
    return stamp;
  }

  /// Throttle bookkeeping: waits until `site` last logged at least a throttle period ago.
  void waitForSite(const std::string& site)
  {
    const auto it = site_hits_.find(site);
    if (site.empty() || it == site_hits_.end())
    {
      return;
    }
    const ros::WallTime free_at = it->second + ros::WallDuration(kThrottleS + 0.2);
    waitFor([&] { return ros::WallTime::now() >= free_at; }, kThrottleS + 1.0);
  }
  void siteHit(const std::string& site) { site_hits_[site] = ros::WallTime::now(); }

  void clearLog() { log_.clear(); }

  ros::NodeHandle nh_;
  ros::Publisher pub_points_, pub_image_, pub_grid_, pub_info_, pub_detections_, pub_projected_;
  ros::Publisher pub_projection_image_, pub_fusion_image_;
  tf2_ros::TransformBroadcaster tf_;
  std::set<ros::Time> bad_outputs_;  ///< stamps of bad inputs whose output a case expects

private:
  ros::Subscriber sub_rosout_, sub_grid_, sub_detections_, sub_projected_, sub_objects_;
  ros::Subscriber sub_overlays_[2];
  std::size_t overlays_ =
      0;  ///< overlay images received (not checked: the overlays only make the nodelets take images)
  std::vector<rosgraph_msgs::Log::ConstPtr> log_;
  std::map<std::string, std::set<ros::Time>> outputs_;
  std::map<std::string, ros::Time> clocks_;
  std::map<std::string, ros::WallTime> site_hits_;
};

std::unique_ptr<Bench> g_bench;

// --- the cases -----------------------------------------------------------------------------------

struct Case
{
  std::string name;
  std::string nodelet;  ///< dynamic_grid, yolo_detector, grid_projection or fusion
  std::function<void(Bench&)> bad;
  std::string expected;  ///< part of the logged line; empty where the input must simply work
  std::string site;      ///< the nodelet's log call site (throttling); empty: not throttled
};

void PrintTo(const Case& c, std::ostream* os)
{
  *os << c.name;
}

/// Publishes `cloud` with the next stamp of the dynamic grid.
std::function<void(Bench&)> badCloud(const std::function<void(sensor_msgs::PointCloud2&)>& spoil)
{
  return [spoil](Bench& b)
  {
    auto cloud = makeCloud(720, b.next("dynamic_grid"), "velo_link");
    spoil(*cloud);
    b.pub_points_.publish(cloud);
  };
}

std::function<void(Bench&)> badImage(const std::function<void(sensor_msgs::Image&)>& spoil)
{
  return [spoil](Bench& b)
  {
    auto image = makeImage(b.next("yolo_detector"));
    spoil(*image);
    b.pub_image_.publish(image);
  };
}

std::function<void(Bench&)> badGrid(const std::function<void(DynamicGrid&)>& spoil)
{
  return [spoil](Bench& b)
  {
    auto grid = makeGrid(b.next("grid_projection"));
    spoil(*grid);
    b.pub_grid_.publish(grid);
  };
}

std::function<void(Bench&)> badInfo(const std::function<void(sensor_msgs::CameraInfo&)>& spoil)
{
  return [spoil](Bench& b)
  {
    // With the grid of its sweep (without it, the camera_info would wait for it).
    const ros::Time stamp = b.next("grid_projection");
    auto info = makeInfo(stamp);
    spoil(*info);
    b.pub_grid_.publish(makeGrid(stamp));
    b.pub_info_.publish(info);
  };
}

std::function<void(Bench&)> badPair(const std::function<void(Detection2DArray&, ProjectedGrid&)>& spoil)
{
  return [spoil](Bench& b)
  {
    const ros::Time stamp = b.next("fusion");
    auto detections = makeDetections(stamp);
    auto projected = makeProjected(stamp);
    spoil(*detections, *projected);
    b.pub_detections_.publish(detections);
    b.pub_projected_.publish(projected);
  };
}

std::vector<Case> cases()
{
  const std::string cloud_fields = "dynamic_grid: cannot use the clouds of /bad/points";
  const std::string image_failed = "yolo_detector: image on /bad/image at t=";
  const std::string grid_dropped = "grid_projection: dropping the grid at t=";
  const std::string info_skipped = "grid_projection: camera_info of /bad/camera_info at t=";
  const std::string pair_dropped = "fusion: dropping the pair at t=";
  // Ordered round-robin over the nodelets so that a call site rarely logs twice within 5 s.
  return {
      {"CloudWithoutZ", "dynamic_grid", badCloud([](sensor_msgs::PointCloud2& c) { c.fields.pop_back(); }),
       cloud_fields, "grid/fields"},
      {"ImageTooShort", "yolo_detector", badImage([](sensor_msgs::Image& i) { i.data.resize(100); }),
       image_failed, "yolo/detect"},
      {"GridTooShort", "grid_projection", badGrid([](DynamicGrid& g) { g.p_static.resize(10); }),
       grid_dropped, "projection/grid"},
      {"NaNBox", "fusion", badPair([](Detection2DArray& d, ProjectedGrid&) { d.detections[0].x_max = kNaN; }),
       pair_dropped, "fusion/pair"},
      {"CameraInfoZeroP", "grid_projection", badInfo([](sensor_msgs::CameraInfo& i) { i.P.fill(0.0); }),
       "P is missing (all zeros)", "projection/skipped"},
      {"CloudFloat64", "dynamic_grid",
       badCloud(
           [](sensor_msgs::PointCloud2& c)
           {
             for (std::size_t k = 0; k < 3; ++k)
             {
               c.fields[k].datatype = sensor_msgs::PointField::FLOAT64;
               c.fields[k].offset = static_cast<std::uint32_t>(8 * k);
             }
             c.point_step = 24;
             c.row_step = 24 * c.width;
             c.data.resize(c.row_step);
           }),
       "is not a single float32", "grid/fields"},
      {"Image16UC1", "yolo_detector",
       badImage(
           [](sensor_msgs::Image& i)
           {
             i.encoding = sensor_msgs::image_encodings::TYPE_16UC1;
             i.step = 128;
             i.data.resize(128 * 32);
           }),
       "\"16UC1\" is not supported", "yolo/detect"},
      {"InvertedBox", "fusion",
       badPair([](Detection2DArray& d, ProjectedGrid&)
               { std::swap(d.detections[0].y_min, d.detections[0].y_max); }),
       "x_min > x_max or y_min > y_max", "fusion/pair"},
      {"CloudBigEndian", "dynamic_grid", badCloud([](sensor_msgs::PointCloud2& c) { c.is_bigendian = true; }),
       "big-endian point data is not supported", "grid/fields"},
      {"GridArraysOfDifferentLengths", "grid_projection",
       badGrid([](DynamicGrid& g) { g.vy.push_back(0.0F); }), "array vy has 101 elements", "projection/grid"},
      {"ImageUnknownEncoding", "yolo_detector",
       badImage([](sensor_msgs::Image& i) { i.encoding = "no_such_encoding"; }),
       "\"no_such_encoding\" is not supported", "yolo/detect"},
      {"ProjectedArraysOfDifferentLengths", "fusion",
       badPair([](Detection2DArray&, ProjectedGrid& p) { p.depth.pop_back(); }),
       "ProjectedGrid arrays differ in length", "fusion/pair"},
      {"CloudNaNPoints", "dynamic_grid",
       badCloud(
           [](sensor_msgs::PointCloud2& c)
           {
             for (std::size_t i = 0; i < 10; ++i)
             {
               std::memcpy(&c.data[16 * i], &kNaN, sizeof(float));
             }
           }),
       "points of /bad/points dropped (NaN/Inf coordinates)", "grid/nan-points"},
      {"CameraInfoNaNP", "grid_projection",
       badInfo([](sensor_msgs::CameraInfo& i) { i.P[2] = std::nan(""); }), "P holds NaN/Inf",
       "projection/skipped"},
      {"ImageZeroByZero", "yolo_detector",
       badImage(
           [](sensor_msgs::Image& i)
           {
             i.width = 0;
             i.height = 0;
             i.step = 0;
             i.data.clear();
           }),
       "image is empty (0x0)", "yolo/detect"},
      {"HundredThousandDetections", "fusion",
       badPair([](Detection2DArray& d, ProjectedGrid&) { d.detections.assign(100000, d.detections[0]); }),
       "100000 detections, more than", "fusion/pair"},
      {"CloudDataTooShort", "dynamic_grid", badCloud([](sensor_msgs::PointCloud2& c) { c.data.resize(160); }),
       "data holds 160 bytes", "grid/fields"},
      {"GridInAnotherFrame", "grid_projection",
       [](Bench& b)
       {
         // The grid's frame has no tf to the camera: every camera_info waits for it until the tf
         // queue (queue_size 5) overflows.
         const ros::Time stamp = b.next("grid_projection");
         b.pub_grid_.publish(makeGrid(stamp, "elsewhere"));
         waitFor([&] { return b.logged("grid_projection: dropping the camera_info of /bad/camera_info"); },
                 kLogTimeoutS, [&] { b.pub_info_.publish(makeInfo(stamp)); });
       },
       "grid_projection: dropping the camera_info of /bad/camera_info", "projection/tf"},
      {"Image20000x20000NotSent", "yolo_detector",
       badImage(
           [](sensor_msgs::Image& i)
           {
             i.width = 20000;
             i.height = 20000;
             i.step = 60000;
             i.data.resize(10);
           }),
       "data holds 10 bytes", "yolo/detect"},
      {"BoxOutsideTheImage", "fusion",
       badPair([](Detection2DArray& d, ProjectedGrid&) { d.detections[0].x_max = 500.0F; }),
       "lies outside the 64x32 image", "fusion/pair"},
      {"CloudEmptyFrameId", "dynamic_grid",
       badCloud([](sensor_msgs::PointCloud2& c) { c.header.frame_id.clear(); }),
       "the cloud has an empty frame_id", "grid/tf"},
      {"OverlayImageTooShort", "grid_projection",
       [](Bench& b)
       {
         auto image = makeImage(b.next("grid_projection"));
         image->data.resize(100);
         b.pub_projection_image_.publish(image);
       },
       "grid_projection: image on /bad/projection_image at t=", "projection/image"},
      {"OverlayImageOfZeroSize", "fusion",
       [](Bench& b)
       {
         auto image = makeImage(b.next("fusion"));
         image->width = 0;
         image->height = 0;
         b.pub_fusion_image_.publish(image);
       },
       "dropped (no overlay for it): image is empty (0x0)", "fusion/image"},
      {"CameraInfoOfZeroSize", "grid_projection",
       badInfo(
           [](sensor_msgs::CameraInfo& i)
           {
             i.width = 0;
             i.height = 0;
           }),
       "camera image size must be > 0", "projection/skipped"},
      {"ImageStepTooSmall", "yolo_detector", badImage([](sensor_msgs::Image& i) { i.step = 64; }),
       "step 64 < width * bytes per pixel = 192", "yolo/detect"},
      {"CameraInfoForAnotherImageSize", "fusion",
       badPair(
           [](Detection2DArray&, ProjectedGrid& p)
           {
             p.image_width = 1242;
             p.image_height = 375;
           }),
       "image size mismatch: detections are for 64x32, projected grid for 1242x375", "fusion/pair"},
      {"CloudTfNeverArrives", "dynamic_grid",
       [](Bench& b)
       {
         // Clouds wait for the tf until more than queue_size (5) wait: one every 100 ms (a burst
         // could overflow the subscriber's queue instead) until the first is pushed out.
         waitFor([&] { return b.logged("dynamic_grid: dropping the scan of /bad/points"); }, kLogTimeoutS,
                 [&] { b.pub_points_.publish(makeCloud(720, b.next("dynamic_grid"), "nowhere_link")); });
       },
       "dynamic_grid: dropping the scan of /bad/points", "grid/tf"},
      {"GridTooOld", "grid_projection",
       [](Bench& b)
       {
         // The lidar falls silent: each camera_info waits for the grid of its sweep until the
         // next one comes, then takes the last grid, 30 s old, and is published without its
         // cells. The lidar comes back for the last.
         const ros::Time stamp = b.next("grid_projection");
         const ros::Time silent = stamp + ros::Duration(30.0);
         const ros::Time back = stamp + ros::Duration(30.1);
         b.pub_grid_.publish(makeGrid(stamp));
         b.pub_info_.publish(makeInfo(silent));
         b.pub_info_.publish(makeInfo(back));
         b.setClock("grid_projection", back);
         b.bad_outputs_.insert(silent);
         b.bad_outputs_.insert(back);
         b.pub_grid_.publish(makeGrid(back));
       },
       "more than max_grid_age", "projection/without_cells"},
      {"GridsWithoutCameraInfo", "grid_projection",
       [](Bench& b)
       {
         // A bag without camera_info: grids come, nothing is projected; after a second the nodelet
         // names the silent topic.
         waitFor([&] { return b.logged("but no camera_infos on /bad/camera_info"); }, kLogTimeoutS,
                 [&] { b.pub_grid_.publish(makeGrid(b.next("grid_projection"))); });
       },
       "grids arrive on /bad/grid_in but no camera_infos on /bad/camera_info for", "projection/stall"},
      {"DetectionsWithoutProjectedGrids", "fusion",
       [](Bench& b)
       {
         ros::Time last;
         waitFor([&] { return b.logged("but no projected grids on /bad/projected_grid_in"); }, kLogTimeoutS,
                 [&]
                 {
                   last = b.next("fusion");
                   b.pub_detections_.publish(makeDetections(last));
                 });
         // The newest one's grid comes late: its pair is fused, which clears the synchronizer's
         // older unmatched detections, and the tracks reset after the gap (hence the site).
         b.bad_outputs_.insert(last);
         b.pub_projected_.publish(makeProjected(last));
         waitFor([&] { return b.output("fusion", last); }, kOutputTimeoutS);  // the reset is logged by then
       },
       "detections arrive on /bad/detections_in but no projected grids on /bad/projected_grid_in for",
       "fusion/reset"},
      {"ModelFileReplacedWhileRunning", "yolo_detector",
       [](Bench& b)
       {
         // The network was read at start; overwriting its files must change nothing.
         for (const std::string& path : {g_model.cfg, g_model.weights})
         {
           std::ofstream(path, std::ios::trunc) << "garbage\n";
         }
         const ros::Time stamp = b.next("yolo_detector");
         b.bad_outputs_.insert(stamp);
         b.pub_image_.publish(makeImage(stamp));
       },
       "", ""},
      {"CloudTimeGoesBackwards", "dynamic_grid",
       [](Bench& b)
       {
         const ros::Time stamp = b.jumpBack("dynamic_grid");
         b.pub_points_.publish(makeCloud(720, stamp, "velo_link"));
       },
       "time jumped backwards by", ""},
      {"PairTimeGoesBackwards", "fusion",
       [](Bench& b)
       {
         const ros::Time stamp = b.jumpBack("fusion");
         b.pub_detections_.publish(makeDetections(stamp));
         b.pub_projected_.publish(makeProjected(stamp));
       },
       "fusion: tracks reset at t=", "fusion/reset"},
      {"GridTimeGoesBackwards", "grid_projection",
       [](Bench& b)
       {
         const ros::Time stamp = b.jumpBack("grid_projection");
         b.pub_grid_.publish(makeGrid(stamp));
         // Again until projected: a camera_info that overtakes the grid goes with the old ones.
         waitFor([&] { return b.output("grid_projection", stamp); }, kOutputTimeoutS,
                 [&] { b.pub_info_.publish(makeInfo(stamp)); });
       },
       "grid_projection: time jumped backwards on", ""},
      {"CameraInfoBeforeItsTf", "grid_projection",
       [](Bench& b)
       {
         const ros::Time stamp = b.next("grid_projection");
         b.pub_grid_.publish(makeGrid(stamp));
         b.pub_info_.publish(makeInfo(stamp, "camera_late"));
         b.bad_outputs_.insert(stamp);
         const auto transforms = lateTransforms("camera_late", stamp, 1.5, true);
         waitFor([&] { return b.output("grid_projection", stamp); }, kOutputTimeoutS,
                 [&] { b.tf_.sendTransform(transforms); });
       },
       "", ""},
      {"CloudBeforeItsTf", "dynamic_grid",
       [](Bench& b)
       {
         // The tf comes right after the cloud, again and again: the moment at which
         // tf2_ros::MessageFilter lost a message now and then (its transform request fired
         // before the message was queued); TfWaitQueue asks the buffer itself.
         const ros::Time stamp = b.next("dynamic_grid");
         b.pub_points_.publish(makeCloud(720, stamp, "late_link"));
         b.bad_outputs_.insert(stamp);
         const auto transforms = lateTransforms("late_link", stamp, 1.73, false);
         waitFor([&] { return b.output("dynamic_grid", stamp); }, kOutputTimeoutS,
                 [&] { b.tf_.sendTransform(transforms); });
       },
       "", ""},
      {"FiveMillionPointCloud", "dynamic_grid",
       [](Bench& b)
       {
         const ros::Time stamp = b.next("dynamic_grid");
         b.bad_outputs_.insert(stamp);
         b.pub_points_.publish(makeCloud(5000000, stamp, "velo_link"));
       },
       "", ""},
      {"CloudClaimsFourBillionPoints", "dynamic_grid",
       badCloud(
           [](sensor_msgs::PointCloud2& c)
           {
             c.width = 65536;
             c.height = 65536;
             c.row_step = 16 * 65536;
           }),
       "row_step * height needs", "grid/fields"},
      {"GridNaNResolution", "grid_projection", badGrid([](DynamicGrid& g) { g.info.resolution = kNaN; }),
       "info.resolution must be finite", "projection/grid"},
  };
}

class BadInput : public ::testing::TestWithParam<Case>
{
};

TEST_P(BadInput, ManagerSurvivesAndRecovers)
{
  const Case& c = GetParam();
  Bench& b = *g_bench;
  ASSERT_TRUE(waitFor([&] { return b.connected(); }, 20.0)) << "the nodelets did not subscribe their inputs";
  b.waitForSite(c.site);
  b.clearLog();
  b.bad_outputs_.clear();
  const ros::WallTime start = ros::WallTime::now();
  c.bad(b);
  if (!c.expected.empty())
  {
    EXPECT_TRUE(waitFor([&] { return b.logged(c.expected); }, kLogTimeoutS))
        << c.name << ": the manager did not log \"" << c.expected << "\"; it logged:\n"
        << b.logText();
    b.siteHit(c.site);
  }
  for (const ros::Time& stamp : b.bad_outputs_)
  {
    EXPECT_TRUE(waitFor([&] { return b.output(c.nodelet, stamp); }, kOutputTimeoutS))
        << c.name << ": no output of " << c.nodelet << " for the input of t=" << stamp.toSec();
  }

  nodelet::NodeletList list;
  ASSERT_TRUE(ros::service::call("/manager/list", list)) << c.name << ": the manager does not answer";
  for (const char* nodelet : kNodelets)
  {
    EXPECT_NE(std::find(list.response.nodelets.begin(), list.response.nodelets.end(), nodelet),
              list.response.nodelets.end())
        << c.name << ": " << nodelet << " is no longer loaded";
  }

  std::vector<ros::Time> good;
  EXPECT_TRUE(waitFor(
      [&] {
        return std::any_of(good.begin(), good.end(),
                           [&](const ros::Time& t) { return b.output(c.nodelet, t); });
      },
      kOutputTimeoutS, [&] { good.push_back(b.publishGood(c.nodelet)); }))
      << c.name << ": " << c.nodelet << " gives no output for good input after the bad one";
  ROS_INFO("bad input case %s took %.2f s", c.name.c_str(), (ros::WallTime::now() - start).toSec());
}

INSTANTIATE_TEST_SUITE_P(Battery, BadInput, ::testing::ValuesIn(cases()),
                         [](const ::testing::TestParamInfo<Case>& info) { return info.param.name; });

bool loadDetector()
{
  nodelet::NodeletLoad load;
  load.request.name = "/yolo_detector";
  load.request.type = "grid_vision_fusion/yolo_detector";
  load.request.remap_source_args = {"image", "detections", "detections/image"};
  load.request.remap_target_args = {"/bad/image", "/bad/detections", "/bad/detections/image"};
  return ros::service::waitForService("/manager/load_nodelet", ros::Duration(20.0)) &&
         ros::service::call("/manager/load_nodelet", load) && load.response.success;
}

}  // namespace
}  // namespace grid_vision_fusion

int main(int argc, char** argv)
{
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_bad_input");
  ros::NodeHandle nh;
  using namespace grid_vision_fusion;
  const std::string model_dir = test::makeTempDirectory();
  g_model = test::writeTinyDarknet(model_dir, test::TinyDarknetSpec());
  ros::param::set("/yolo_detector/model", g_model.cfg);
  ros::param::set("/yolo_detector/weights", g_model.weights);
  ros::param::set("/yolo_detector/class_names", g_model.names);
  ros::param::set("/yolo_detector/score_threshold", 0.6);
  if (!loadDetector())
  {
    ADD_FAILURE() << "cannot load the yolo_detector nodelet into /manager";
  }
  // Static tf: the lidar 1.73 m and the camera 1.5 m above the origin of "odom" (the grid's default fixed
  // frame).
  tf2_ros::StaticTransformBroadcaster broadcaster;
  broadcaster.sendTransform(
      std::vector<geometry_msgs::TransformStamped>{transform("camera_optical", ros::Time::now(), 1.5, true),
                                                   transform("velo_link", ros::Time::now(), 1.73, false)});
  g_bench = std::make_unique<Bench>();
  const int result = RUN_ALL_TESTS();
  g_bench.reset();
  std::filesystem::remove_all(model_dir);
  return result;
}
