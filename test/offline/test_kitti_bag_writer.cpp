// Tests of the KITTI drive → bag conversion (no master needed: rosbag reads and writes files).
// The drive is built in a temporary folder from the real calibration, OXTS records and time stamps
// of 2011_09_26 drive 0001 (test/data, KITTI, CC BY-NC-SA 3.0), plus small synthetic images and
// scans (the fixtures hold none).
#include <gtest/gtest.h>

#include "grid_vision_fusion/offline/kitti_bag_writer.h"

#include <geometry_msgs/TwistStamped.h>
#include <image_geometry/pinhole_camera_model.h>
#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>
#include <sensor_msgs/Imu.h>
#include <sensor_msgs/NavSatFix.h>
#include <sensor_msgs/PointCloud2.h>
#include <tf2/buffer_core.h>
#include <tf2_eigen/tf2_eigen.h>
#include <tf2_msgs/TFMessage.h>

#include <opencv2/imgcodecs.hpp>

#include <sys/wait.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <map>
#include <sstream>
#include <string>
#include <vector>

namespace grid_vision_fusion
{
namespace
{
namespace fs = std::filesystem;

const std::string kDay = std::string(GVF_TEST_DATA_DIR) + "/kitti_raw_2011_09_26";
const std::string kDrive = kDay + "/2011_09_26_drive_0001_sync";
constexpr int kFrames = 5;
constexpr int kWidth = 1242;  // S_rect_0i of 2011_09_26
constexpr int kHeight = 375;

std::string indexName(int frame, const char* extension)
{
  std::ostringstream name;
  name << std::setw(10) << std::setfill('0') << frame << extension;
  return name.str();
}

/// The velodyne points of frame `frame`: (x, y, z, reflectance), distinct per frame.
std::vector<std::array<float, 4>> scanPoints(int frame)
{
  return {{10.F, 0.F, -1.73F, 0.5F}, {10.F, 0.F, 0.F, 0.25F}, {5.F + frame, 2.F, 0.5F, 1.F}};
}

/// A KITTI layout in a fresh temporary folder: <root>/2011_09_26/{calib_*.txt, <drive>/...}.
class KittiDriveFixture : public ::testing::Test
{
protected:
  void SetUp() override
  {
    char pattern[] = "/tmp/gvf_kitti_to_bag_XXXXXX";
    ASSERT_NE(mkdtemp(pattern), nullptr);
    root_ = pattern;
    day_ = root_ + "/2011_09_26";
    drive_ = day_ + "/2011_09_26_drive_0001_sync";
    bag_ = root_ + "/out.bag";
    for (const char* file : {"calib_cam_to_cam.txt", "calib_velo_to_cam.txt", "calib_imu_to_velo.txt"})
    {
      copy(kDay + "/" + file, day_ + "/" + file);
    }
    for (const char* folder : {"image_00", "image_01", "image_02", "image_03", "oxts", "velodyne_points"})
    {
      copy(kDrive + "/" + folder + "/timestamps.txt", drive_ + "/" + folder + "/timestamps.txt");
      fs::create_directories(drive_ + "/" + folder + "/data");
    }
    for (int frame = 0; frame < kFrames; ++frame)
    {
      copy(kDrive + "/oxts/data/" + indexName(frame, ".txt"),
           drive_ + "/oxts/data/" + indexName(frame, ".txt"));
      writeScan(drive_ + "/velodyne_points/data/" + indexName(frame, ".bin"), scanPoints(frame));
      for (int camera = 0; camera < 4; ++camera)
      {
        writeImage(camera, frame);
      }
    }
  }

  void TearDown() override
  {
    std::error_code ignored;
    fs::remove_all(root_, ignored);
  }

  static void copy(const std::string& from, const std::string& to)
  {
    fs::create_directories(fs::path(to).parent_path());
    fs::copy_file(from, to, fs::copy_options::overwrite_existing);
  }

  static void writeScan(const std::string& path, const std::vector<std::array<float, 4>>& points)
  {
    std::ofstream file(path, std::ios::binary);
    for (const auto& point : points)
    {
      file.write(reinterpret_cast<const char*>(point.data()), sizeof(float) * 4);
    }
  }

  /// Colour images: black, pixel (u = 20 + frame, v = 10) pure blue in OpenCV's BGR order;
  /// grey images: 0, that pixel 200.
  void writeImage(int camera, int frame) const
  {
    const std::string path =
        drive_ + "/image_0" + std::to_string(camera) + "/data/" + indexName(frame, ".png");
    if (camera < 2)
    {
      cv::Mat image(kHeight, kWidth, CV_8UC1, cv::Scalar(0));
      image.at<std::uint8_t>(10, 20 + frame) = 200;
      ASSERT_TRUE(cv::imwrite(path, image));
    }
    else
    {
      cv::Mat image(kHeight, kWidth, CV_8UC3, cv::Scalar(0, 0, 0));
      image.at<cv::Vec3b>(10, 20 + frame) = cv::Vec3b(255, 0, 0);
      ASSERT_TRUE(cv::imwrite(path, image));
    }
  }

  KittiBagOptions options() const
  {
    KittiBagOptions options;
    options.drive_dir = drive_;
    options.output_bag = bag_;
    return options;
  }

  /// Every message of the bag by topic, in time order.
  std::map<std::string, std::vector<rosbag::MessageInstance>> readBag() const
  {
    std::map<std::string, std::vector<rosbag::MessageInstance>> messages;
    bag_in_.open(bag_, rosbag::bagmode::Read);
    rosbag::View view(bag_in_);
    for (const rosbag::MessageInstance& m : view)
    {
      messages[m.getTopic()].push_back(m);
    }
    return messages;
  }

  /// Expects the conversion to throw a std::runtime_error whose message holds `needle`, and no
  /// bag (nor its temporary) to be left behind.
  void expectFailureNaming(const KittiBagOptions& options, const std::string& needle) const
  {
    try
    {
      convertKittiDrive(options);
      ADD_FAILURE() << "no error, expected one naming " << needle;
    }
    catch (const std::runtime_error& e)
    {
      EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
    }
    EXPECT_FALSE(fs::exists(bag_));
    EXPECT_FALSE(fs::exists(bag_ + ".tmp"));
  }

  std::string root_, day_, drive_, bag_;
  mutable rosbag::Bag bag_in_;
};

std::vector<ros::Time> rosStamps(const std::string& path)
{
  std::vector<ros::Time> stamps;
  for (const KittiStamp& s : readTimestamps(path))
  {
    stamps.push_back(toRosTime(s));
  }
  return stamps;
}

/// (yaw, pitch, roll) of R = Rz(yaw)·Ry(pitch)·Rx(roll), pitch in (−π/2, π/2).
Eigen::Vector3d yawPitchRoll(const Eigen::Matrix3d& r)
{
  return {std::atan2(r(1, 0), r(0, 0)), -std::asin(r(2, 0)), std::atan2(r(2, 1), r(2, 2))};
}

/// A BufferCore fed with the /tf_static transforms of the bag.
void feedStatic(tf2::BufferCore& buffer, const std::vector<rosbag::MessageInstance>& static_messages)
{
  for (const auto& m : static_messages)
  {
    const tf2_msgs::TFMessage::ConstPtr message = m.instantiate<tf2_msgs::TFMessage>();
    ASSERT_TRUE(message);
    for (const auto& t : message->transforms)
    {
      EXPECT_TRUE(buffer.setTransform(t, "bag", true)) << t.header.frame_id << " -> " << t.child_frame_id;
    }
  }
}
}  // namespace

TEST_F(KittiDriveFixture, CountsStampsAndFramesPerTopic)
{
  std::vector<std::pair<std::size_t, std::size_t>> progress;
  KittiBagOptions opts = options();
  opts.progress = [&progress](std::size_t done, std::size_t total) { progress.emplace_back(done, total); };
  const KittiBagSummary summary = convertKittiDrive(opts);
  EXPECT_EQ(summary.frames, 5U);
  EXPECT_EQ(summary.messages, 2U + 5U * 7U);  // tf_static, the first frame's lead pose, 7 per frame
  ASSERT_EQ(progress.size(), 5U);
  using Progress = std::pair<std::size_t, std::size_t>;
  EXPECT_EQ(progress.front(), Progress(1, 5));
  EXPECT_EQ(progress.back(), Progress(5, 5));

  const auto bag = readBag();
  const std::map<std::string, std::size_t> expected_counts = {{"/tf_static", 1U},
                                                              {"/tf", 6U},
                                                              {"/kitti/oxts/imu", 5U},
                                                              {"/kitti/oxts/gps/fix", 5U},
                                                              {"/kitti/oxts/gps/vel", 5U},
                                                              {"/kitti/velo/pointcloud", 5U},
                                                              {"/kitti/camera_color_left/image_raw", 5U},
                                                              {"/kitti/camera_color_left/camera_info", 5U}};
  ASSERT_EQ(bag.size(), expected_counts.size());
  for (const auto& [topic, count] : expected_counts)
  {
    ASSERT_EQ(bag.count(topic), 1U) << topic;
    EXPECT_EQ(bag.at(topic).size(), count) << topic;
  }

  const auto oxts = rosStamps(kDrive + "/oxts/timestamps.txt");
  const auto velo = rosStamps(kDrive + "/velodyne_points/timestamps.txt");
  const auto image = rosStamps(kDrive + "/image_02/timestamps.txt");
  // The first one by hand: 2011-09-26 13:02:25.964389445 UTC.
  EXPECT_EQ(oxts[0], ros::Time(1317042145, 964389445));
  for (int i = 0; i < kFrames; ++i)
  {
    const auto k = static_cast<std::size_t>(i);
    const auto tf = bag.at("/tf")[k + 1].instantiate<tf2_msgs::TFMessage>();  // after the lead pose
    ASSERT_EQ(tf->transforms.size(), 2U);
    for (const auto& t : tf->transforms)
    {
      EXPECT_EQ(t.header.stamp, oxts[k]);
    }
    // REP 105: world -> odom -> base_link.
    EXPECT_EQ(tf->transforms[0].header.frame_id, "world");
    EXPECT_EQ(tf->transforms[0].child_frame_id, "odom");
    EXPECT_EQ(tf->transforms[1].header.frame_id, "odom");
    EXPECT_EQ(tf->transforms[1].child_frame_id, "base_link");
    EXPECT_EQ(bag.at("/tf")[k + 1].getTime(), oxts[k]);

    const auto imu = bag.at("/kitti/oxts/imu")[k].instantiate<sensor_msgs::Imu>();
    EXPECT_EQ(imu->header.stamp, oxts[k]);
    EXPECT_EQ(imu->header.frame_id, "imu_link");
    const auto fix = bag.at("/kitti/oxts/gps/fix")[k].instantiate<sensor_msgs::NavSatFix>();
    EXPECT_EQ(fix->header.stamp, oxts[k]);
    EXPECT_EQ(fix->header.frame_id, "imu_link");
    const auto vel = bag.at("/kitti/oxts/gps/vel")[k].instantiate<geometry_msgs::TwistStamped>();
    EXPECT_EQ(vel->header.stamp, oxts[k]);

    const auto cloud = bag.at("/kitti/velo/pointcloud")[k].instantiate<sensor_msgs::PointCloud2>();
    EXPECT_EQ(cloud->header.stamp, velo[k]);
    EXPECT_EQ(bag.at("/kitti/velo/pointcloud")[k].getTime(), velo[k]);
    EXPECT_EQ(cloud->header.frame_id, "velo_link");
    EXPECT_EQ(cloud->header.seq, k) << "header.seq is the KITTI frame index";

    const auto img = bag.at("/kitti/camera_color_left/image_raw")[k].instantiate<sensor_msgs::Image>();
    EXPECT_EQ(img->header.stamp, image[k]);
    EXPECT_EQ(img->header.frame_id, "camera_color_left");
    EXPECT_EQ(img->header.seq, k);
    const auto info =
        bag.at("/kitti/camera_color_left/camera_info")[k].instantiate<sensor_msgs::CameraInfo>();
    EXPECT_EQ(info->header.stamp, image[k]);
    EXPECT_EQ(info->header.frame_id, "camera_color_left");
    EXPECT_EQ(info->header.seq, k);
  }
  // /tf_static comes first (before every sensor message of frame 0) and is stored latched.
  const rosbag::MessageInstance& static_tf = bag.at("/tf_static")[0];
  EXPECT_EQ(static_tf.getTime(), std::min({oxts[0], velo[0], image[0]}));
  EXPECT_EQ(static_tf.getConnectionHeader()->at("latching"), "1");
  // The output is complete: no temporary left.
  EXPECT_FALSE(fs::exists(bag_ + ".tmp"));
}

TEST_F(KittiDriveFixture, OxtsMessagesCarryTheRecordValues)
{
  convertKittiDrive(options());
  const auto bag = readBag();
  const OxtsRecord record = parseOxtsLine(
      [&]
      {
        std::ifstream file(kDrive + "/oxts/data/" + indexName(1, ".txt"));
        std::string line;
        std::getline(file, line);
        return line;
      }(),
      "oxts 1");
  const auto imu = bag.at("/kitti/oxts/imu")[1].instantiate<sensor_msgs::Imu>();
  // Body frame values of record 1 (wx, wy, wz; ax, ay, az), by hand from the file.
  EXPECT_DOUBLE_EQ(imu->angular_velocity.x, 0.0045821736870773);
  EXPECT_DOUBLE_EQ(imu->angular_velocity.y, -0.013397509586964);
  EXPECT_DOUBLE_EQ(imu->angular_velocity.z, -0.021380134026467);
  EXPECT_DOUBLE_EQ(imu->linear_acceleration.x, -0.53556232143028);
  EXPECT_DOUBLE_EQ(imu->linear_acceleration.y, 0.18671710579457);
  EXPECT_DOUBLE_EQ(imu->linear_acceleration.z, 10.078281781295);  // gravity included (REP 145)
  // Orientation: back to roll, pitch, yaw (ZYX).
  const Eigen::Quaterniond q(imu->orientation.w, imu->orientation.x, imu->orientation.y, imu->orientation.z);
  const Eigen::Vector3d ypr = yawPitchRoll(q.toRotationMatrix());
  EXPECT_NEAR(ypr[0], record.yaw, 1e-9);
  EXPECT_NEAR(ypr[1], record.pitch, 1e-9);
  EXPECT_NEAR(ypr[2], record.roll, 1e-9);

  const auto fix = bag.at("/kitti/oxts/gps/fix")[1].instantiate<sensor_msgs::NavSatFix>();
  EXPECT_DOUBLE_EQ(fix->latitude, record.lat);
  EXPECT_DOUBLE_EQ(fix->latitude, 49.014997147797);
  EXPECT_DOUBLE_EQ(fix->longitude, 8.4342801643975);
  EXPECT_DOUBLE_EQ(fix->altitude, record.alt);
  EXPECT_DOUBLE_EQ(fix->position_covariance[0], record.pos_accuracy * record.pos_accuracy);

  const auto vel = bag.at("/kitti/oxts/gps/vel")[1].instantiate<geometry_msgs::TwistStamped>();
  EXPECT_DOUBLE_EQ(vel->twist.linear.x, 13.129879921905);  // vf
  EXPECT_DOUBLE_EQ(vel->twist.linear.y, record.vl);
  EXPECT_DOUBLE_EQ(vel->twist.angular.z, -0.021891250950339);  // wu
}

namespace
{
/// world ← base_link of the k-th /tf message: world ← odom ← base_link.
Eigen::Isometry3d worldFromBase(const std::vector<rosbag::MessageInstance>& tf, std::size_t k)
{
  const auto msg = tf.at(k).instantiate<tf2_msgs::TFMessage>();
  return tf2::transformToEigen(msg->transforms.at(0)) * tf2::transformToEigen(msg->transforms.at(1));
}
}  // namespace

TEST_F(KittiDriveFixture, TfOfFrameOneIsTheOxtsPoseRelativeToFrameZero)
{
  convertKittiDrive(options());
  const auto bag = readBag();
  EXPECT_TRUE(worldFromBase(bag.at("/tf"), 1).isApprox(Eigen::Isometry3d::Identity(), 1e-12));

  const Eigen::Isometry3d pose1 = worldFromBase(bag.at("/tf"), 2);
  // Hand values (KITTI devkit convertOxtsToPose on records 0 and 1 of drive 0001).
  EXPECT_NEAR(pose1.translation().x(), 1.4424816836, 1e-6);
  EXPECT_NEAR(pose1.translation().y(), 0.0124398614, 1e-6);
  EXPECT_NEAR(pose1.translation().z(), 0.0145361725, 1e-6);
  const Eigen::Vector3d ypr = yawPitchRoll(pose1.linear());
  EXPECT_NEAR(ypr[0], -0.0022599650, 1e-7);

  const auto poses = oxtsPosesRelativeToFirst(readOxtsFolder(drive_ + "/oxts"));
  for (int i = 0; i < kFrames; ++i)
  {
    const auto k = static_cast<std::size_t>(i);
    EXPECT_TRUE(worldFromBase(bag.at("/tf"), k + 1).isApprox(poses[k], 1e-9)) << "frame " << i;
  }
}

TEST_F(KittiDriveFixture, OdomIsTheOxtsTrackLaidAlongItsHeading)
{
  convertKittiDrive(options());
  const auto bag = readBag();
  const std::vector<OxtsRecord> records = readOxtsFolder(drive_ + "/oxts");
  const auto poses =
      oxtsPosesRelativeToFirst(std::vector<OxtsRecord>(records.begin(), records.begin() + kFrames));
  const auto odometry = alongHeadingPoses(poses);
  for (int i = 0; i < kFrames; ++i)
  {
    const auto k = static_cast<std::size_t>(i);
    const auto msg = bag.at("/tf")[k + 1].instantiate<tf2_msgs::TFMessage>();
    const Eigen::Isometry3d odom_from_base = tf2::transformToEigen(msg->transforms.at(1));
    EXPECT_TRUE(odom_from_base.isApprox(odometry[k], 1e-9)) << "frame " << i;
    // world <- odom is the difference of the two positions: a translation, zero at frame 0.
    const Eigen::Isometry3d world_from_odom = tf2::transformToEigen(msg->transforms.at(0));
    EXPECT_TRUE(world_from_odom.linear().isApprox(Eigen::Matrix3d::Identity(), 1e-9)) << "frame " << i;
    EXPECT_NEAR(world_from_odom.translation().norm(),
                (poses[k].translation() - odometry[k].translation()).norm(), 1e-9);
  }
  // Drive 0001 at 13 m/s: the OXTS track leaves the heading by a few centimetres over 0.4 s.
  EXPECT_GT((poses.back().translation() - odometry.back().translation()).norm(), 1e-4);
  EXPECT_LT((poses.back().translation() - odometry.back().translation()).norm(), 0.1);
}

TEST_F(KittiDriveFixture, TheFirstFrameGetsAPoseAtItsEarliestSensorStamp)
{
  // Drive 0001's first scan is stamped 13.2 ms before its first OXTS record: the first pose is
  // also written then, moved back along the record's velocity, so that the scan has a pose.
  convertKittiDrive(options());
  const auto bag = readBag();
  const auto velo = rosStamps(kDrive + "/velodyne_points/timestamps.txt");
  const auto oxts = rosStamps(kDrive + "/oxts/timestamps.txt");
  const double lead = (oxts[0] - velo[0]).toSec();
  ASSERT_GT(lead, 0.013);
  ASSERT_LT(lead, 0.014);
  const auto lead_tf = bag.at("/tf")[0].instantiate<tf2_msgs::TFMessage>();
  ASSERT_EQ(lead_tf->transforms.size(), 2U);
  EXPECT_TRUE(tf2::transformToEigen(lead_tf->transforms[0]).isApprox(Eigen::Isometry3d::Identity(), 1e-12))
      << "world and odom coincide at the first frame";
  const auto& first = lead_tf->transforms[1];
  EXPECT_EQ(first.header.stamp, velo[0]) << "the earliest sensor stamp of frame 0 is the scan's";
  const OxtsRecord record = readOxtsFolder(drive_ + "/oxts").front();
  const Eigen::Isometry3d before = tf2::transformToEigen(first);
  EXPECT_NEAR(before.translation().x(), -record.vf * lead, 1e-3);
  EXPECT_NEAR(before.translation().y(), -record.vl * lead, 1e-3);
  EXPECT_TRUE(before.isApprox(poseBefore(Eigen::Isometry3d::Identity(), record, lead), 1e-9));
}

TEST(PoseBefore, UndoesAConstantTwist)
{
  // 10 m/s forward, turning left at 0.5 rad/s: moving 0.1 s on from poseBefore(pose, 0.1) along
  // the same twist lands on the pose again.
  OxtsRecord record;
  record.vf = 10.0;
  record.vl = 0.2;
  record.wu = 0.5;
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.translate(Eigen::Vector3d(3.0, -1.0, 0.2));
  pose.rotate(Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitZ()));
  const Eigen::Isometry3d before = poseBefore(pose, record, 0.1);
  Eigen::Isometry3d step = Eigen::Isometry3d::Identity();
  step.linear() = Eigen::AngleAxisd(0.05, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  step.translation() = Eigen::Vector3d(1.0, 0.02, 0.0);
  EXPECT_TRUE((before * step).isApprox(pose, 1e-12));
  EXPECT_TRUE(poseBefore(pose, OxtsRecord{}, 0.1).isApprox(pose, 1e-12)) << "standing: the same pose";
}

TEST_F(KittiDriveFixture, StaticTransformChainFollowsTheCalibration)
{
  convertKittiDrive(options());
  const auto bag = readBag();
  tf2::BufferCore buffer;
  feedStatic(buffer, bag.at("/tf_static"));
  ASSERT_EQ(bag.at("/tf_static")[0].instantiate<tf2_msgs::TFMessage>()->transforms.size(), 3U);

  const Eigen::Isometry3d imu_from_base =
      tf2::transformToEigen(buffer.lookupTransform("imu_link", "base_link", ros::Time(0)));
  EXPECT_TRUE(imu_from_base.isApprox(Eigen::Isometry3d::Identity(), 1e-12));
  // calib_imu_to_velo.txt: a point of the IMU frame lands at R·p + T in the velodyne frame.
  const Eigen::Isometry3d velo_from_imu =
      tf2::transformToEigen(buffer.lookupTransform("velo_link", "imu_link", ros::Time(0)));
  // (1e-6: the file's rotation is orthonormal to ~1e-7 only, the quaternion of the message is.)
  EXPECT_NEAR(velo_from_imu.translation().x(), -8.086759e-01, 1e-6);
  EXPECT_NEAR(velo_from_imu.translation().y(), 3.195559e-01, 1e-6);
  EXPECT_NEAR(velo_from_imu.translation().z(), -7.997231e-01, 1e-6);
  EXPECT_NEAR(velo_from_imu.linear()(0, 1), 7.553071e-04, 1e-6);
  // Camera ← velodyne: the velodyne origin seen from camera 2. By hand: R_rect_00 · T of
  // calib_velo_to_cam has x = −0.0027968; camera 2's centre t_2 = K⁻¹ · (44.85728, 0.2163791,
  // 0.002745884) has x = (44.85728 − 609.5593 · 0.002745884) / 721.5377 = 0.0598493.
  const KittiRawCalibration calibration = KittiRawCalibration::readDirectory(kDay);
  const Eigen::Vector3d centre = kittiCameraCentre(calibration, 2);
  EXPECT_NEAR(centre.x(), 0.0598493, 1e-7);
  EXPECT_NEAR(centre.y(), (0.2163791 - 172.854 * 0.002745884) / 721.5377, 1e-9);
  EXPECT_NEAR(centre.z(), 0.002745884, 1e-12);
  const Eigen::Isometry3d camera_from_velo =
      tf2::transformToEigen(buffer.lookupTransform("camera_color_left", "velo_link", ros::Time(0)));
  EXPECT_TRUE(camera_from_velo.isApprox(kittiCameraFromVelo(calibration, 2), 1e-6));
  EXPECT_NEAR(camera_from_velo.translation().x(), -0.0027968 + 0.0598493, 1e-6);
  // The whole chain base_link → camera exists.
  EXPECT_TRUE(buffer.canTransform("camera_color_left", "base_link", ros::Time(0)));
}

TEST_F(KittiDriveFixture, CameraInfoCarriesTheRectifiedModel)
{
  convertKittiDrive(options());
  const auto info =
      readBag().at("/kitti/camera_color_left/camera_info")[0].instantiate<sensor_msgs::CameraInfo>();
  EXPECT_EQ(info->width, 1242U);  // S_rect_02
  EXPECT_EQ(info->height, 375U);
  EXPECT_EQ(info->distortion_model, "plumb_bob");
  EXPECT_EQ(info->D, std::vector<double>(5, 0.0));
  const std::array<double, 9> k = {7.215377e+02, 0, 6.095593e+02, 0, 7.215377e+02, 1.728540e+02, 0, 0, 1};
  const std::array<double, 9> r = {1, 0, 0, 0, 1, 0, 0, 0, 1};
  const std::array<double, 12> p = {
      7.215377e+02, 0, 6.095593e+02, 0, 0, 7.215377e+02, 1.728540e+02, 0, 0, 0, 1, 0};
  for (std::size_t i = 0; i < 9; ++i)
  {
    EXPECT_DOUBLE_EQ(info->K[i], k[i]) << "K[" << i << "]";
    EXPECT_DOUBLE_EQ(info->R[i], r[i]) << "R[" << i << "]";
  }
  for (std::size_t i = 0; i < 12; ++i)
  {
    EXPECT_DOUBLE_EQ(info->P[i], p[i]) << "P[" << i << "]";
  }
}

TEST_F(KittiDriveFixture, ImageGeometryProjectsVelodynePointsLikeTheKittiChain)
{
  convertKittiDrive(options());
  const auto bag = readBag();
  tf2::BufferCore buffer;
  feedStatic(buffer, bag.at("/tf_static"));
  const Eigen::Isometry3d camera_from_velo =
      tf2::transformToEigen(buffer.lookupTransform("camera_color_left", "velo_link", ros::Time(0)));
  image_geometry::PinholeCameraModel model;
  ASSERT_TRUE(model.fromCameraInfo(
      bag.at("/kitti/camera_color_left/camera_info")[0].instantiate<sensor_msgs::CameraInfo>()));

  const KittiRawCalibration calibration = KittiRawCalibration::readDirectory(kDay);
  const ProjectionMatrix kitti = calibration.veloToImage(2);
  struct Case
  {
    Eigen::Vector3d velo;
    cv::Point2d pixel;  // by hand: P_rect_02 · R_rect_00 · Tr_velo_to_cam · (X, 1)
  };
  for (const Case& c : {Case{{10.0, 0.0, -1.73}, {615.3, 303.5}}, Case{{10.0, 0.0, 0.0}, {614.0, 175.0}},
                        Case{{20.0, 5.0, -1.0}, {0.0, 0.0}}})
  {
    const Eigen::Vector3d x = camera_from_velo * c.velo;
    const cv::Point2d uv = model.project3dToPixel(cv::Point3d(x.x(), x.y(), x.z()));
    const Eigen::Vector3d h = kitti * c.velo.homogeneous();
    // (1e-4 px: the calibration's rotations are orthonormal to ~1e-7 only, tf's quaternions are.)
    EXPECT_NEAR(uv.x, h.x() / h.z(), 1e-4) << c.velo.transpose();
    EXPECT_NEAR(uv.y, h.y() / h.z(), 1e-4) << c.velo.transpose();
    if (c.pixel.x > 0.0)
    {
      EXPECT_NEAR(uv.x, c.pixel.x, 0.5) << c.velo.transpose();
      EXPECT_NEAR(uv.y, c.pixel.y, 0.5) << c.velo.transpose();
    }
  }
}

TEST_F(KittiDriveFixture, ImagesAreRgbAndScansKeepTheirPoints)
{
  convertKittiDrive(options());
  const auto bag = readBag();
  for (int i = 0; i < kFrames; ++i)
  {
    const auto k = static_cast<std::size_t>(i);
    const auto img = bag.at("/kitti/camera_color_left/image_raw")[k].instantiate<sensor_msgs::Image>();
    ASSERT_EQ(img->encoding, "rgb8");
    ASSERT_EQ(img->width, 1242U);
    ASSERT_EQ(img->height, 375U);
    ASSERT_EQ(img->step, 1242U * 3U);
    // Blue in the PNG (BGR 255, 0, 0) is RGB (0, 0, 255) in the bag.
    const std::size_t at = 10U * img->step + (20U + k) * 3U;
    EXPECT_EQ(img->data[at], 0);
    EXPECT_EQ(img->data[at + 2], 255);
    EXPECT_EQ(img->data[at + 3 + 2], 0);

    const auto cloud = bag.at("/kitti/velo/pointcloud")[k].instantiate<sensor_msgs::PointCloud2>();
    ASSERT_EQ(cloud->fields.size(), 4U);
    const char* names[] = {"x", "y", "z", "intensity"};
    for (std::size_t f = 0; f < 4; ++f)
    {
      EXPECT_EQ(cloud->fields[f].name, names[f]);
      EXPECT_EQ(cloud->fields[f].offset, 4U * f);
      EXPECT_EQ(cloud->fields[f].datatype, sensor_msgs::PointField::FLOAT32);
    }
    EXPECT_EQ(cloud->point_step, 16U);
    EXPECT_EQ(cloud->width, 3U);
    EXPECT_TRUE(cloud->is_dense);
    const auto points = scanPoints(i);
    ASSERT_EQ(cloud->data.size(), points.size() * 16U);
    for (std::size_t p = 0; p < points.size(); ++p)
    {
      std::array<float, 4> read{};
      std::memcpy(read.data(), cloud->data.data() + 16U * p, 16U);
      EXPECT_EQ(read, points[p]) << "frame " << i << " point " << p;
    }
  }
}

TEST_F(KittiDriveFixture, FrameRangeAndCamerasAreOptions)
{
  KittiBagOptions opts = options();
  opts.first_frame = 2;
  opts.last_frame = 3;
  opts.cameras = {2, 3, 0};
  EXPECT_EQ(convertKittiDrive(opts).frames, 2U);
  const auto bag = readBag();
  EXPECT_EQ(bag.at("/tf").size(), 3U);  // the lead pose of frame 2, then frames 2 and 3
  EXPECT_EQ(bag.at("/kitti/camera_color_right/image_raw").size(), 2U);
  EXPECT_EQ(bag.at("/kitti/camera_gray_left/image_raw").size(), 2U);
  EXPECT_EQ(bag.count("/kitti/camera_gray_right/image_raw"), 0U);

  // The first frame of the range is the origin of world.
  const auto tf = bag.at("/tf")[1].instantiate<tf2_msgs::TFMessage>()->transforms.at(0);
  EXPECT_EQ(tf.header.stamp, rosStamps(kDrive + "/oxts/timestamps.txt")[2]);
  EXPECT_TRUE(tf2::transformToEigen(tf).isApprox(Eigen::Isometry3d::Identity(), 1e-12));

  const auto grey = bag.at("/kitti/camera_gray_left/image_raw")[0].instantiate<sensor_msgs::Image>();
  EXPECT_EQ(grey->encoding, "mono8");
  EXPECT_EQ(grey->header.frame_id, "camera_gray_left");
  EXPECT_EQ(grey->header.stamp, rosStamps(kDrive + "/image_00/timestamps.txt")[2]);
  EXPECT_EQ(grey->data[10U * grey->step + 22U], 200);

  // The right colour camera sits 0.47 m left of camera 0 (P_rect_03: tx = −339.5242 px / fx).
  tf2::BufferCore buffer;
  feedStatic(buffer, bag.at("/tf_static"));
  const auto right_from_left =
      buffer.lookupTransform("camera_color_right", "camera_color_left", ros::Time(0));
  EXPECT_NEAR(right_from_left.transform.translation.x, (-3.395242e+02 - 4.485728e+01) / 7.215377e+02, 1e-4);
  const auto info = bag.at("/kitti/camera_color_right/camera_info")[0].instantiate<sensor_msgs::CameraInfo>();
  EXPECT_EQ(info->header.frame_id, "camera_color_right");
  EXPECT_DOUBLE_EQ(info->P[3], 0.0);
}

TEST_F(KittiDriveFixture, InvalidOptionsAreRefused)
{
  KittiBagOptions opts = options();
  opts.cameras = {2, 2};
  EXPECT_THROW(convertKittiDrive(opts), std::invalid_argument);
  opts.cameras = {4};
  EXPECT_THROW(convertKittiDrive(opts), std::invalid_argument);
  opts = options();
  opts.first_frame = 3;
  opts.last_frame = 1;
  EXPECT_THROW(convertKittiDrive(opts), std::invalid_argument);
  opts = options();
  opts.first_frame = 7;  // the drive has 5 scans
  EXPECT_THROW(convertKittiDrive(opts), std::invalid_argument);
  opts = options();
  opts.compression = "zip";
  EXPECT_THROW(convertKittiDrive(opts), std::invalid_argument);
  EXPECT_FALSE(fs::exists(bag_));
}

TEST_F(KittiDriveFixture, DefaultCalibrationFolderIsTheParentOfTheDrive)
{
  KittiBagOptions opts = options();
  EXPECT_EQ(opts.calibrationDirectory(), day_);
  opts.drive_dir = drive_ + "/";
  EXPECT_EQ(opts.calibrationDirectory(), day_);
  opts.calibration_dir = "/elsewhere";
  EXPECT_EQ(opts.calibrationDirectory(), "/elsewhere");
}

TEST_F(KittiDriveFixture, TruncatedScanIsAnErrorNamingTheFile)
{
  const std::string scan = drive_ + "/velodyne_points/data/" + indexName(3, ".bin");
  fs::resize_file(scan, 16 * 2 + 7);
  expectFailureNaming(options(), scan);
  expectFailureNaming(options(), "not a multiple of 16");
}

TEST_F(KittiDriveFixture, MissingImageIsAnErrorNamingTheFile)
{
  const std::string image = drive_ + "/image_02/data/" + indexName(2, ".png");
  fs::remove(image);
  expectFailureNaming(options(), image);
}

TEST_F(KittiDriveFixture, UndecodableOrWrongSizedImageIsAnError)
{
  const std::string image = drive_ + "/image_02/data/" + indexName(1, ".png");
  std::ofstream(image) << "not a png";
  expectFailureNaming(options(), image);
  cv::imwrite(image, cv::Mat(370, 1224, CV_8UC3, cv::Scalar(1, 2, 3)));  // a 2011_09_28-sized image
  expectFailureNaming(options(), "S_rect_02");
}

TEST_F(KittiDriveFixture, MissingCalibrationKeyIsAnErrorNamingFileAndKey)
{
  std::ifstream in(kDay + "/calib_cam_to_cam.txt");
  std::ofstream out(day_ + "/calib_cam_to_cam.txt");
  std::string line;
  while (std::getline(in, line))
  {
    if (line.rfind("P_rect_02:", 0) != 0)
    {
      out << line << '\n';
    }
  }
  out.close();
  expectFailureNaming(options(), day_ + "/calib_cam_to_cam.txt");
  expectFailureNaming(options(), "P_rect_02");
}

TEST_F(KittiDriveFixture, ShortTimestampsFileIsAnErrorNamingTheFile)
{
  const std::string path = drive_ + "/velodyne_points/timestamps.txt";
  const auto stamps = readTimestamps(path);
  std::ifstream in(path);
  std::string text, line;
  for (int i = 0; i < 3 && std::getline(in, line); ++i)
  {
    text += line + "\n";
  }
  in.close();
  std::ofstream(path) << text;
  expectFailureNaming(options(), path);
}

TEST_F(KittiDriveFixture, MissingDriveFolderIsAnErrorNamingIt)
{
  KittiBagOptions opts = options();
  opts.drive_dir = root_ + "/no_such_drive";
  expectFailureNaming(opts, opts.drive_dir);
}

TEST_F(KittiDriveFixture, MissingOxtsRecordIsAnErrorNamingTheFile)
{
  const std::string record = drive_ + "/oxts/data/" + indexName(4, ".txt");
  fs::remove(record);
  expectFailureNaming(options(), record);
}

TEST_F(KittiDriveFixture, AFailedConversionLeavesAnOlderBagUntouched)
{
  std::ofstream(bag_) << "previous";
  fs::resize_file(drive_ + "/velodyne_points/data/" + indexName(4, ".bin"), 5);
  EXPECT_THROW(convertKittiDrive(options()), std::runtime_error);
  EXPECT_FALSE(fs::exists(bag_ + ".tmp"));
  std::ifstream in(bag_);
  std::string content;
  in >> content;
  EXPECT_EQ(content, "previous");
}

/// The command-line tool: exit codes and messages.
class KittiToBagTool : public KittiDriveFixture
{
protected:
  /// Runs kitti_to_bag with `arguments`; returns its exit status, `output` gets stdout + stderr.
  static int run(const std::string& arguments, std::string& output)
  {
    const std::string command = std::string(GVF_KITTI_TO_BAG) + " " + arguments + " 2>&1";
    FILE* pipe = popen(command.c_str(), "r");
    if (pipe == nullptr)
    {
      return -1;
    }
    output.clear();
    std::array<char, 512> buffer{};
    while (std::fgets(buffer.data(), buffer.size(), pipe) != nullptr)
    {
      output += buffer.data();
    }
    const int status = pclose(pipe);
    return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  }
};

TEST_F(KittiToBagTool, ConvertsAndReportsProgress)
{
  std::string output;
  EXPECT_EQ(run("--last 2 --cameras 2,3 " + drive_ + " " + bag_, output), 0) << output;
  EXPECT_NE(output.find("kitti_to_bag frames: 3/3 (100 %)"), std::string::npos) << output;
  EXPECT_EQ(readBag().at("/kitti/camera_color_right/image_raw").size(), 3U);
}

TEST_F(KittiToBagTool, UsageErrorsExitWithTwo)
{
  std::string output;
  EXPECT_EQ(run("--help", output), 0);
  EXPECT_NE(output.find("Usage: kitti_to_bag"), std::string::npos) << output;
  EXPECT_EQ(run(drive_, output), 2);
  EXPECT_NE(output.find("want DRIVE_DIR and OUTPUT.bag"), std::string::npos) << output;
  EXPECT_EQ(run("--first x " + drive_ + " " + bag_, output), 2);
  EXPECT_NE(output.find("--first wants a frame index"), std::string::npos) << output;
  EXPECT_EQ(run("--cameras 2,5 " + drive_ + " " + bag_, output), 2);
  EXPECT_EQ(run("--bogus " + drive_ + " " + bag_, output), 2);
  EXPECT_NE(output.find("unknown option --bogus"), std::string::npos) << output;
  EXPECT_FALSE(fs::exists(bag_));
}

TEST_F(KittiToBagTool, ConversionErrorExitsWithOneNamingTheFile)
{
  const std::string scan = drive_ + "/velodyne_points/data/" + indexName(1, ".bin");
  fs::resize_file(scan, 15);
  std::string output;
  EXPECT_EQ(run("-q " + drive_ + " " + bag_, output), 1);
  EXPECT_NE(output.find("kitti_to_bag: error: truncated velodyne scan " + scan), std::string::npos) << output;
  EXPECT_FALSE(fs::exists(bag_));
  EXPECT_FALSE(fs::exists(bag_ + ".tmp"));
}

}  // namespace grid_vision_fusion
