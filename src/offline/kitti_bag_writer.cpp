#include "grid_vision_fusion/offline/kitti_bag_writer.h"

#include "grid_vision_fusion/cli/temporary_output.h"

#include <cv_bridge/cv_bridge.h>
#include <ros/message_traits.h>
#include <rosbag/bag.h>
#include <sensor_msgs/NavSatStatus.h>
#include <sensor_msgs/PointField.h>
#include <tf2_msgs/TFMessage.h>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <boost/make_shared.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <limits>
#include <set>
#include <sstream>
#include <stdexcept>

#if !defined(__BYTE_ORDER__) || __BYTE_ORDER__ != __ORDER_LITTLE_ENDIAN__
#error "kitti_bag_writer copies the little-endian float32 KITTI scans as they are: little-endian hosts only"
#endif

namespace grid_vision_fusion
{
namespace
{
namespace fs = std::filesystem;

constexpr const char* kWorldFrame = "world";
constexpr const char* kOdomFrame = "odom";
constexpr const char* kBaseFrame = "base_link";
constexpr const char* kImuFrame = "imu_link";
constexpr const char* kVeloFrame = "velo_link";
constexpr const char* kVeloTopic = "/kitti/velo/pointcloud";
constexpr const char* kImuTopic = "/kitti/oxts/imu";
constexpr const char* kGpsFixTopic = "/kitti/oxts/gps/fix";
constexpr const char* kGpsVelTopic = "/kitti/oxts/gps/vel";
constexpr std::size_t kVelodynePointBytes = 4 * sizeof(float);

std::string frameFile(const std::string& drive_dir, const std::string& folder, int frame,
                      const char* extension)
{
  std::ostringstream path;
  path << drive_dir << '/' << folder << "/data/" << std::setw(10) << std::setfill('0') << frame << extension;
  return path.str();
}

/// Time stamps of one sensor folder, checked to cover frame `last`.
std::vector<KittiStamp> readSensorStamps(const std::string& drive_dir, const std::string& folder, int last)
{
  const std::string path = drive_dir + '/' + folder + "/timestamps.txt";
  if (!fs::exists(path))
  {
    throw std::runtime_error("missing timestamps file " + path);
  }
  std::vector<KittiStamp> stamps = readTimestamps(path);
  if (stamps.size() <= static_cast<std::size_t>(last))
  {
    throw std::runtime_error("timestamps file " + path + " holds " + std::to_string(stamps.size()) +
                             " time stamps, frame " + std::to_string(last) + " needs " +
                             std::to_string(last + 1));
  }
  return stamps;
}

/// Number of velodyne scans of the drive: the .bin files of velodyne_points/data.
int countVelodyneScans(const std::string& drive_dir)
{
  const fs::path folder = fs::path(drive_dir) / "velodyne_points" / "data";
  std::error_code error;
  if (!fs::is_directory(folder, error))
  {
    throw std::runtime_error("missing velodyne folder " + folder.string());
  }
  int count = 0;
  for (const auto& entry : fs::directory_iterator(folder))
  {
    if (entry.path().extension() == ".bin")
    {
      ++count;
    }
  }
  if (count == 0)
  {
    throw std::runtime_error("no velodyne scan (*.bin) in " + folder.string());
  }
  return count;
}

rosbag::compression::CompressionType compressionType(const std::string& name)
{
  if (name == "none")
  {
    return rosbag::compression::Uncompressed;
  }
  if (name == "bz2")
  {
    return rosbag::compression::BZ2;
  }
  return rosbag::compression::LZ4;
}

/// A connection header marking `T` on a topic as latched, as rosbag record stores /tf_static.
template <typename T>
boost::shared_ptr<ros::M_string> latchedConnectionHeader()
{
  auto header = boost::make_shared<ros::M_string>();
  (*header)["type"] = ros::message_traits::datatype<T>();
  (*header)["md5sum"] = ros::message_traits::md5sum<T>();
  (*header)["message_definition"] = ros::message_traits::definition<T>();
  (*header)["callerid"] = "/kitti_to_bag";
  (*header)["latching"] = "1";
  return header;
}

geometry_msgs::Quaternion toQuaternionMsg(const Eigen::Matrix3d& rotation)
{
  const Eigen::Quaterniond q = Eigen::Quaterniond(rotation).normalized();
  geometry_msgs::Quaternion msg;
  msg.x = q.x();
  msg.y = q.y();
  msg.z = q.z();
  msg.w = q.w();
  return msg;
}

}  // namespace

KittiCameraNames kittiCameraNames(int camera)
{
  static const char* const kNames[] = {"camera_gray_left", "camera_gray_right", "camera_color_left",
                                       "camera_color_right"};
  if (camera < 0 || camera > 3)
  {
    throw std::out_of_range("KITTI camera index " + std::to_string(camera) + " is not in 0..3");
  }
  KittiCameraNames names;
  names.name = kNames[camera];
  names.image_topic = "/kitti/" + names.name + "/image_raw";
  names.info_topic = "/kitti/" + names.name + "/camera_info";
  names.folder = "image_0" + std::to_string(camera);
  names.encoding = camera < 2 ? "mono8" : "rgb8";
  return names;
}

std::string KittiBagOptions::calibrationDirectory() const
{
  if (!calibration_dir.empty())
  {
    return calibration_dir;
  }
  fs::path drive(drive_dir);
  if (!drive.has_filename())
  {
    drive = drive.parent_path();  // "…/drive_sync/" names the same folder as "…/drive_sync"
  }
  const fs::path parent = drive.parent_path();
  return parent.empty() ? std::string(".") : parent.string();
}

void KittiBagOptions::validate() const
{
  if (drive_dir.empty())
  {
    throw std::invalid_argument("drive_dir is empty");
  }
  if (output_bag.empty())
  {
    throw std::invalid_argument("output_bag is empty");
  }
  if (first_frame < 0)
  {
    throw std::invalid_argument("first_frame is negative (" + std::to_string(first_frame) + ")");
  }
  if (last_frame >= 0 && last_frame < first_frame)
  {
    throw std::invalid_argument("last_frame (" + std::to_string(last_frame) + ") is before first_frame (" +
                                std::to_string(first_frame) + ")");
  }
  std::set<int> seen;
  for (const int camera : cameras)
  {
    if (camera < 0 || camera > 3)
    {
      throw std::invalid_argument("cameras: " + std::to_string(camera) + " is not a KITTI camera (0..3)");
    }
    if (!seen.insert(camera).second)
    {
      throw std::invalid_argument("cameras: camera " + std::to_string(camera) + " is listed twice");
    }
  }
  if (compression != "none" && compression != "bz2" && compression != "lz4")
  {
    throw std::invalid_argument("compression is \"" + compression + "\", want none, bz2 or lz4");
  }
}

ros::Time toRosTime(const KittiStamp& stamp)
{
  if (stamp.sec < 0 || stamp.sec > static_cast<std::int64_t>(std::numeric_limits<std::uint32_t>::max()) ||
      stamp.nsec >= 1000000000u || (stamp.sec == 0 && stamp.nsec == 0))
  {
    throw std::runtime_error("time stamp " + std::to_string(stamp.sec) + "." + std::to_string(stamp.nsec) +
                             " s is outside the range of ros::Time");
  }
  return ros::Time(static_cast<std::uint32_t>(stamp.sec), stamp.nsec);
}

geometry_msgs::TransformStamped toTransformMsg(const Eigen::Isometry3d& parent_from_child,
                                               const std::string& parent, const std::string& child,
                                               const ros::Time& stamp)
{
  geometry_msgs::TransformStamped msg;
  msg.header.stamp = stamp;
  msg.header.frame_id = parent;
  msg.child_frame_id = child;
  msg.transform.translation.x = parent_from_child.translation().x();
  msg.transform.translation.y = parent_from_child.translation().y();
  msg.transform.translation.z = parent_from_child.translation().z();
  msg.transform.rotation = toQuaternionMsg(parent_from_child.linear());
  return msg;
}

Eigen::Vector3d kittiCameraCentre(const KittiRawCalibration& calibration, int camera)
{
  kittiCameraNames(camera);  // range check
  const ProjectionMatrix& p = calibration.p_rect[static_cast<std::size_t>(camera)];
  const Eigen::Matrix3d k = p.leftCols<3>();
  if (!p.allFinite() || !(k(0, 0) > 0.0) || !(k(1, 1) > 0.0) || k(1, 0) != 0.0 || k(2, 0) != 0.0 ||
      k(2, 1) != 0.0 || k(2, 2) != 1.0)
  {
    throw std::runtime_error(
        "P_rect_0" + std::to_string(camera) +
        " is not the projection matrix of a rectified camera (want [fx s cx tx; 0 fy cy ty; "
        "0 0 1 tz] with fx, fy > 0)");
  }
  return k.triangularView<Eigen::Upper>().solve(p.col(3));
}

Eigen::Isometry3d kittiCameraFromVelo(const KittiRawCalibration& calibration, int camera)
{
  return Eigen::Translation3d(kittiCameraCentre(calibration, camera)) * calibration.rectifiedFromVelo();
}

std::vector<geometry_msgs::TransformStamped> kittiStaticTransforms(const KittiRawCalibration& calibration,
                                                                   const std::vector<int>& cameras,
                                                                   const ros::Time& stamp)
{
  std::vector<geometry_msgs::TransformStamped> transforms;
  transforms.push_back(toTransformMsg(Eigen::Isometry3d::Identity(), kBaseFrame, kImuFrame, stamp));
  transforms.push_back(toTransformMsg(calibration.velo_from_imu.inverse(), kImuFrame, kVeloFrame, stamp));
  for (const int camera : cameras)
  {
    transforms.push_back(toTransformMsg(kittiCameraFromVelo(calibration, camera).inverse(), kVeloFrame,
                                        kittiCameraNames(camera).name, stamp));
  }
  return transforms;
}

sensor_msgs::CameraInfo kittiCameraInfo(const KittiRawCalibration& calibration, int camera,
                                        const ros::Time& stamp)
{
  const KittiCameraNames names = kittiCameraNames(camera);
  kittiCameraCentre(calibration, camera);  // checks the form of P_rect_0i
  const auto index = static_cast<std::size_t>(camera);
  const ProjectionMatrix& p = calibration.p_rect[index];
  sensor_msgs::CameraInfo info;
  info.header.stamp = stamp;
  info.header.frame_id = names.name;
  info.width = calibration.image_size[index][0];
  info.height = calibration.image_size[index][1];
  info.distortion_model = "plumb_bob";
  info.D.assign(5, 0.0);
  for (int r = 0; r < 3; ++r)
  {
    for (int c = 0; c < 3; ++c)
    {
      info.K[static_cast<std::size_t>(3 * r + c)] = p(r, c);
      info.R[static_cast<std::size_t>(3 * r + c)] = r == c ? 1.0 : 0.0;
      info.P[static_cast<std::size_t>(4 * r + c)] = p(r, c);
    }
    info.P[static_cast<std::size_t>(4 * r + 3)] = 0.0;  // the offset t_i lives in tf
  }
  return info;
}

sensor_msgs::PointCloud2 readVelodyneScan(const std::string& path, const ros::Time& stamp)
{
  std::error_code error;
  if (!fs::is_regular_file(path, error))
  {
    throw std::runtime_error("missing frame: velodyne scan " + path + " does not exist");
  }
  const std::uintmax_t bytes = fs::file_size(path, error);
  if (error)
  {
    throw std::runtime_error("cannot read the size of velodyne scan " + path + ": " + error.message());
  }
  if (bytes % kVelodynePointBytes != 0)
  {
    throw std::runtime_error("truncated velodyne scan " + path + ": " + std::to_string(bytes) +
                             " bytes is not a multiple of 16 (float32 x, y, z, reflectance per point)");
  }
  sensor_msgs::PointCloud2 cloud;
  cloud.header.stamp = stamp;
  cloud.header.frame_id = kVeloFrame;
  cloud.height = 1;
  cloud.width = static_cast<std::uint32_t>(bytes / kVelodynePointBytes);
  const char* const names[] = {"x", "y", "z", "intensity"};
  for (std::uint32_t i = 0; i < 4; ++i)
  {
    sensor_msgs::PointField field;
    field.name = names[i];
    field.offset = i * static_cast<std::uint32_t>(sizeof(float));
    field.datatype = sensor_msgs::PointField::FLOAT32;
    field.count = 1;
    cloud.fields.push_back(field);
  }
  cloud.is_bigendian = false;
  cloud.point_step = static_cast<std::uint32_t>(kVelodynePointBytes);
  cloud.row_step = cloud.point_step * cloud.width;
  cloud.data.resize(static_cast<std::size_t>(bytes));
  std::ifstream file(path, std::ios::binary);
  if (!file || !file.read(reinterpret_cast<char*>(cloud.data.data()), static_cast<std::streamsize>(bytes)))
  {
    throw std::runtime_error("cannot read velodyne scan " + path);
  }
  cloud.is_dense = true;
  for (std::size_t offset = 0; offset < cloud.data.size() && cloud.is_dense; offset += kVelodynePointBytes)
  {
    float xyz[3];
    std::memcpy(xyz, cloud.data.data() + offset, sizeof(xyz));
    cloud.is_dense = std::isfinite(xyz[0]) && std::isfinite(xyz[1]) && std::isfinite(xyz[2]);
  }
  return cloud;
}

sensor_msgs::Image readKittiImage(const std::string& path, int camera, std::uint32_t expected_width,
                                  std::uint32_t expected_height, const ros::Time& stamp)
{
  const KittiCameraNames names = kittiCameraNames(camera);
  std::error_code error;
  if (!fs::is_regular_file(path, error))
  {
    throw std::runtime_error("missing frame: image " + path + " does not exist");
  }
  const bool colour = names.encoding == "rgb8";
  cv::Mat image = cv::imread(path, colour ? cv::IMREAD_COLOR : cv::IMREAD_GRAYSCALE);
  if (image.empty())
  {
    throw std::runtime_error("cannot decode image " + path);
  }
  if (static_cast<std::uint32_t>(image.cols) != expected_width ||
      static_cast<std::uint32_t>(image.rows) != expected_height)
  {
    throw std::runtime_error("image " + path + " is " + std::to_string(image.cols) + "x" +
                             std::to_string(image.rows) + " px, the calibration (S_rect_0" +
                             std::to_string(camera) + ") says " + std::to_string(expected_width) + "x" +
                             std::to_string(expected_height) +
                             ": wrong calibration folder or not a rectified _sync image");
  }
  if (colour)
  {
    cv::cvtColor(image, image, cv::COLOR_BGR2RGB);
  }
  std_msgs::Header header;
  header.stamp = stamp;
  header.frame_id = names.name;
  sensor_msgs::Image msg;
  cv_bridge::CvImage(header, names.encoding, image).toImageMsg(msg);
  return msg;
}

sensor_msgs::Imu oxtsToImu(const OxtsRecord& record, const ros::Time& stamp)
{
  sensor_msgs::Imu imu;
  imu.header.stamp = stamp;
  imu.header.frame_id = kImuFrame;
  imu.orientation = toQuaternionMsg((Eigen::AngleAxisd(record.yaw, Eigen::Vector3d::UnitZ()) *
                                     Eigen::AngleAxisd(record.pitch, Eigen::Vector3d::UnitY()) *
                                     Eigen::AngleAxisd(record.roll, Eigen::Vector3d::UnitX()))
                                        .toRotationMatrix());
  // The body-frame rates and accelerations (x front, y left, z top of the vehicle), as imu_link;
  // wf/wl/wu and af/al/au are about the level (heading-only) frame.
  imu.angular_velocity.x = record.wx;
  imu.angular_velocity.y = record.wy;
  imu.angular_velocity.z = record.wz;
  imu.linear_acceleration.x = record.ax;
  imu.linear_acceleration.y = record.ay;
  imu.linear_acceleration.z = record.az;
  return imu;
}

sensor_msgs::NavSatFix oxtsToNavSatFix(const OxtsRecord& record, const ros::Time& stamp)
{
  sensor_msgs::NavSatFix fix;
  fix.header.stamp = stamp;
  fix.header.frame_id = kImuFrame;
  fix.status.status = sensor_msgs::NavSatStatus::STATUS_FIX;
  fix.status.service = sensor_msgs::NavSatStatus::SERVICE_GPS;
  fix.latitude = record.lat;
  fix.longitude = record.lon;
  fix.altitude = record.alt;
  const double variance = record.pos_accuracy * record.pos_accuracy;
  fix.position_covariance[0] = variance;
  fix.position_covariance[4] = variance;
  fix.position_covariance[8] = variance;
  fix.position_covariance_type = sensor_msgs::NavSatFix::COVARIANCE_TYPE_APPROXIMATED;
  return fix;
}

Eigen::Isometry3d poseBefore(const Eigen::Isometry3d& pose, const OxtsRecord& record, double dt)
{
  const Eigen::Vector3d velocity(record.vf, record.vl, record.vu);
  const Eigen::Vector3d rate(record.wf, record.wl, record.wu);
  Eigen::Isometry3d step = Eigen::Isometry3d::Identity();  // the motion over dt, in the body frame
  const double angle = rate.norm() * dt;
  if (angle > 0.0)
  {
    step.linear() = Eigen::AngleAxisd(angle, rate.normalized()).toRotationMatrix();
  }
  step.translation() = velocity * dt;
  return pose * step.inverse();
}

geometry_msgs::TwistStamped oxtsToTwist(const OxtsRecord& record, const ros::Time& stamp)
{
  geometry_msgs::TwistStamped twist;
  twist.header.stamp = stamp;
  twist.header.frame_id = kImuFrame;
  twist.twist.linear.x = record.vf;
  twist.twist.linear.y = record.vl;
  twist.twist.linear.z = record.vu;
  twist.twist.angular.x = record.wf;
  twist.twist.angular.y = record.wl;
  twist.twist.angular.z = record.wu;
  return twist;
}

namespace
{
/// What convertKittiDrive() writes: every input read and checked to cover the frames before the
/// bag is opened.
struct DriveInputs
{
  KittiRawCalibration calibration;
  int first = 0;
  int last = 0;
  std::vector<KittiStamp> velo_stamps, oxts_stamps;
  std::vector<KittiCameraNames> cameras;
  std::vector<std::vector<KittiStamp>> camera_stamps;  ///< per camera of `cameras`
  std::vector<OxtsRecord> records;                     ///< from frame `first` to `last`
  std::vector<Eigen::Isometry3d> poses, odometry;      ///< of `records`
  ros::Time start;  ///< the earliest stamp of the first frame: the static transforms'
};

/// Every camera of `options` has a calibration.
void checkCameraCalibration(const KittiBagOptions& options, const KittiRawCalibration& calibration)
{
  for (const int camera : options.cameras)
  {
    try
    {
      kittiCameraCentre(calibration, camera);
    }
    catch (const std::runtime_error& e)
    {
      throw std::runtime_error("KITTI calibration file " + options.calibrationDirectory() +
                               "/calib_cam_to_cam.txt: " + e.what());
    }
  }
}

/// The OXTS records of the frames `first` to `last`.
std::vector<OxtsRecord> oxtsRecords(const std::string& drive, int first, int last)
{
  std::vector<OxtsRecord> records = readOxtsFolder(drive + "/oxts");
  if (records.size() <= static_cast<std::size_t>(last))
  {
    throw std::runtime_error("missing frame: OXTS record " +
                             frameFile(drive, "oxts", static_cast<int>(records.size()), ".txt") +
                             " does not exist (frame " + std::to_string(last) + " requested)");
  }
  return std::vector<OxtsRecord>(records.begin() + first, records.begin() + last + 1);
}

DriveInputs readDriveInputs(const KittiBagOptions& options)
{
  const std::string& drive = options.drive_dir;
  std::error_code error;
  if (!fs::is_directory(drive, error))
  {
    throw std::runtime_error("missing drive folder " + drive);
  }
  DriveInputs in;
  in.calibration = KittiRawCalibration::readDirectory(options.calibrationDirectory());
  checkCameraCalibration(options, in.calibration);

  in.first = options.first_frame;
  in.last = options.last_frame >= 0 ? options.last_frame : countVelodyneScans(drive) - 1;
  if (in.last < in.first)
  {
    throw std::invalid_argument("first_frame " + std::to_string(in.first) + " is after the last frame of " +
                                drive + " (" + std::to_string(in.last) + ")");
  }
  in.velo_stamps = readSensorStamps(drive, "velodyne_points", in.last);
  in.oxts_stamps = readSensorStamps(drive, "oxts", in.last);
  for (const int camera : options.cameras)
  {
    in.cameras.push_back(kittiCameraNames(camera));
    in.camera_stamps.push_back(readSensorStamps(drive, in.cameras.back().folder, in.last));
  }
  in.records = oxtsRecords(drive, in.first, in.last);
  in.poses = oxtsPosesRelativeToFirst(in.records);
  in.odometry = alongHeadingPoses(in.poses);

  // The static transforms precede every message of the first frame.
  const auto first = static_cast<std::size_t>(in.first);
  in.start = toRosTime(in.velo_stamps[first]);
  in.start = std::min(in.start, toRosTime(in.oxts_stamps[first]));
  for (const auto& stamps : in.camera_stamps)
  {
    in.start = std::min(in.start, toRosTime(stamps[first]));
  }
  return in;
}

/// Writes messages into a bag being written to `temporary`, counting them in `summary`.
struct BagWriter
{
  rosbag::Bag& bag;
  const std::string& temporary;
  KittiBagSummary& summary;

  template <class Message>
  void operator()(const std::string& topic, const ros::Time& stamp, const Message& msg,
                  const boost::shared_ptr<ros::M_string>& connection_header = {})
  {
    try
    {
      bag.write(topic, stamp, msg, connection_header);
    }
    catch (const rosbag::BagException& e)
    {
      throw std::runtime_error("cannot write " + topic + " to bag " + temporary + ": " + e.what());
    }
    ++summary.messages;
  }
};

/// The static transforms and, when the first OXTS record comes shortly after them, the pose
/// extrapolated back to their stamp.
void writeStart(BagWriter& write, const DriveInputs& in, const KittiBagOptions& options)
{
  tf2_msgs::TFMessage static_tf;
  static_tf.transforms = kittiStaticTransforms(in.calibration, options.cameras, in.start);
  write("/tf_static", in.start, static_tf, latchedConnectionHeader<tf2_msgs::TFMessage>());
  const double lead = (toRosTime(in.oxts_stamps[static_cast<std::size_t>(in.first)]) - in.start).toSec();
  if (lead > 0.0 && lead <= kMaxPoseExtrapolationS)
  {
    tf2_msgs::TFMessage tf;
    tf.transforms.push_back(toTransformMsg(Eigen::Isometry3d::Identity(), kWorldFrame, kOdomFrame, in.start));
    tf.transforms.push_back(toTransformMsg(poseBefore(in.odometry.front(), in.records.front(), lead),
                                           kOdomFrame, kBaseFrame, in.start));
    write("/tf", in.start, tf);
  }
}

/// One frame's messages: the transforms and the OXTS messages, the scan, each camera's image
/// and camera_info.
void writeFrame(BagWriter& write, const DriveInputs& in, const KittiBagOptions& options, int frame)
{
  const auto index = static_cast<std::size_t>(frame);
  const std::size_t local = index - static_cast<std::size_t>(in.first);

  const ros::Time oxts_stamp = toRosTime(in.oxts_stamps[index]);
  // REP 105: world → odom → base_link. The grid and the tracks live in the continuous odom
  // frame; world ← base_link is the OXTS pose, as before.
  tf2_msgs::TFMessage tf;
  tf.transforms.push_back(
      toTransformMsg(in.poses[local] * in.odometry[local].inverse(), kWorldFrame, kOdomFrame, oxts_stamp));
  tf.transforms.push_back(toTransformMsg(in.odometry[local], kOdomFrame, kBaseFrame, oxts_stamp));
  write("/tf", oxts_stamp, tf);
  write(kImuTopic, oxts_stamp, oxtsToImu(in.records[local], oxts_stamp));
  write(kGpsFixTopic, oxts_stamp, oxtsToNavSatFix(in.records[local], oxts_stamp));
  write(kGpsVelTopic, oxts_stamp, oxtsToTwist(in.records[local], oxts_stamp));

  // Sensor messages carry the KITTI frame index in header.seq, so that per-frame files
  // (e.g. label_2 for the detection replay) can be found from a message.
  const std::string& drive = options.drive_dir;
  const ros::Time velo_stamp = toRosTime(in.velo_stamps[index]);
  sensor_msgs::PointCloud2 cloud =
      readVelodyneScan(frameFile(drive, "velodyne_points", frame, ".bin"), velo_stamp);
  cloud.header.seq = static_cast<std::uint32_t>(frame);
  write(kVeloTopic, velo_stamp, cloud);

  for (std::size_t c = 0; c < in.cameras.size(); ++c)
  {
    const int camera = options.cameras[c];
    const auto& size = in.calibration.image_size[static_cast<std::size_t>(camera)];
    const ros::Time stamp = toRosTime(in.camera_stamps[c][index]);
    sensor_msgs::Image image = readKittiImage(frameFile(drive, in.cameras[c].folder, frame, ".png"), camera,
                                              size[0], size[1], stamp);
    image.header.seq = static_cast<std::uint32_t>(frame);
    write(in.cameras[c].image_topic, stamp, image);
    sensor_msgs::CameraInfo info = kittiCameraInfo(in.calibration, camera, stamp);
    info.header.seq = static_cast<std::uint32_t>(frame);
    write(in.cameras[c].info_topic, stamp, info);
  }
}

/// The bag at `temporary`: the start, then every frame.
void writeBag(const std::string& temporary, const DriveInputs& in, const KittiBagOptions& options,
              KittiBagSummary& summary)
{
  rosbag::Bag bag;
  try
  {
    bag.open(temporary, rosbag::bagmode::Write);
  }
  catch (const rosbag::BagException& e)
  {
    throw std::runtime_error("cannot write bag " + temporary + ": " + e.what());
  }
  bag.setCompression(compressionType(options.compression));
  BagWriter write{bag, temporary, summary};
  writeStart(write, in, options);
  const auto total = static_cast<std::size_t>(in.last - in.first + 1);
  for (int frame = in.first; frame <= in.last; ++frame)
  {
    writeFrame(write, in, options, frame);
    ++summary.frames;
    if (options.progress)
    {
      options.progress(summary.frames, total);
    }
  }
  try
  {
    bag.close();
  }
  catch (const rosbag::BagException& e)
  {
    throw std::runtime_error("cannot finish bag " + temporary + ": " + e.what());
  }
}
}  // namespace

KittiBagSummary convertKittiDrive(const KittiBagOptions& options)
{
  options.validate();
  const DriveInputs in = readDriveInputs(options);
  TemporaryOutput output(options.output_bag);
  KittiBagSummary summary;
  summary.output_bag = options.output_bag;
  writeBag(output.temporary(), in, options, summary);
  output.commit();
  return summary;
}

}  // namespace grid_vision_fusion
