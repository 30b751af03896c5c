// Tests of the synthetic drive writer: the written drive is read back with the KITTI readers and
// checked against the scenario's ground truth and the day's calibration.
#include <gtest/gtest.h>

#include <opencv2/imgcodecs.hpp>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>

#include "grid_vision_fusion/detection/kitti_labels.h"
#include "grid_vision_fusion/kitti/kitti_raw.h"
#include "grid_vision_fusion/simulation/synthetic_drive.h"

namespace grid_vision_fusion
{
namespace
{
namespace fs = std::filesystem;
const std::string kCalibration = std::string(GVF_SOURCE_DIR) + "/test/data/kitti_raw_2011_09_26";

/// 3 frames at 10 Hz: the ego drives at 10 m/s along +x; a parked car 15 m ahead on the right,
/// an oncoming car at 8 m/s 30 m ahead on the left.
SyntheticScenario smallScenario()
{
  SyntheticScenario s;
  s.duration_s = 0.3;
  s.ego = Trajectory::waypoints({{0.0, 0.0, -1.75}, {1.0, 10.0, -1.75}});
  Actor parked;
  parked.type = "Car";
  parked.length = 4.0;
  parked.width = 1.8;
  parked.height = 1.5;
  parked.trajectory = Trajectory::parked({15.0, -5.0, 0.0});
  Actor oncoming = parked;
  oncoming.type = "Van";
  oncoming.height = 2.2;
  oncoming.trajectory = Trajectory::waypoints({{0.0, 30.0, 1.75}, {1.0, 22.0, 1.75}});
  s.actors = {parked, oncoming};
  s.lidar.azimuth_steps = 512;
  return s;
}

struct Drive
{
  SyntheticDriveSummary summary;
  Drive()
  {
    SyntheticDriveOptions options;
    options.output_root = (fs::path(testing::TempDir()) / "synthetic_drive").string();
    options.calibration_dir = kCalibration;
    fs::remove_all(options.output_root);
    int calls = 0;
    summary = writeSyntheticDrive(smallScenario(), options,
                                  [&](int done, int total)
                                  {
                                    ++calls;
                                    EXPECT_EQ(done, calls);
                                    EXPECT_EQ(total, 3);
                                  });
    EXPECT_EQ(calls, 3);
  }
};

const Drive& drive()
{
  static const Drive instance;
  return instance;
}
}  // namespace

TEST(SyntheticDrive, KittiRawLayout)
{
  const fs::path dir = drive().summary.drive_dir;
  EXPECT_EQ(dir.filename(), "2011_09_26_drive_9001_sync");
  EXPECT_EQ(drive().summary.frames, 3);
  for (const char* file : {"calib_cam_to_cam.txt", "calib_velo_to_cam.txt", "calib_imu_to_velo.txt"})
  {
    EXPECT_TRUE(fs::exists(dir.parent_path() / file)) << file;
  }
  for (const char* file : {"image_02/data/0000000002.png", "velodyne_points/data/0000000002.bin",
                           "oxts/data/0000000002.txt", "oxts/dataformat.txt", "label_2/0000000002.txt",
                           "tracklet_labels.xml", "velodyne_points/timestamps_start.txt"})
  {
    EXPECT_TRUE(fs::exists(dir / file)) << file;
  }
  const cv::Mat image = cv::imread((dir / "image_02/data/0000000000.png").string());
  EXPECT_EQ(image.size(), cv::Size(1242, 375));  // S_rect_02
  const auto bytes = fs::file_size(dir / "velodyne_points/data/0000000000.bin");
  EXPECT_EQ(bytes % 16, 0U);
  EXPECT_GT(bytes / 16, 512U * 40U);  // most of the 64 beams of 512 columns hit something
}

TEST(SyntheticDrive, OxtsAndTimestampsReadBack)
{
  const fs::path dir = drive().summary.drive_dir;
  const std::vector<KittiStamp> stamps = readTimestamps((dir / "image_02/timestamps.txt").string());
  ASSERT_EQ(stamps.size(), 3U);
  EXPECT_EQ(stamps[0].sec, 1317042000);  // 2011-09-26 13:00:00 UTC
  const auto nanoseconds = [](const KittiStamp& s) { return s.sec * 1000000000LL + s.nsec; };
  EXPECT_EQ(nanoseconds(stamps[2]) - nanoseconds(stamps[0]), 200000000LL);
  const std::vector<KittiStamp> starts =
      readTimestamps((dir / "velodyne_points/timestamps_start.txt").string());
  EXPECT_EQ(nanoseconds(stamps[0]) - nanoseconds(starts[0]), 50000000LL);
  // The IMU moves 1 m per frame along world x = east = OXTS yaw 0.
  const std::vector<OxtsRecord> records = readOxtsFolder((dir / "oxts").string());
  ASSERT_EQ(records.size(), 3U);
  const std::vector<Eigen::Isometry3d> poses = oxtsPosesRelativeToFirst(records);
  EXPECT_NEAR(poses[2].translation().x(), 2.0, 1e-3);
  EXPECT_NEAR(poses[2].translation().y(), 0.0, 1e-3);
  EXPECT_NEAR(records[1].vf, 10.0, 1e-9);
  EXPECT_NEAR(records[1].ve, 10.0, 1e-9);
  EXPECT_NEAR(records[1].yaw, 0.0, 1e-12);
  // The IMU sits below the velodyne (1.73 m above the road) by the height of the velodyne in
  // the IMU frame, about 0.80 m (calib_imu_to_velo).
  const KittiRawCalibration calibration = KittiRawCalibration::readDirectory(kCalibration);
  const double velo_above_imu = calibration.velo_from_imu.inverse().translation().z();
  EXPECT_NEAR(velo_above_imu, 0.80, 0.01);
  EXPECT_NEAR(records[0].alt - 116.0, 1.73 - velo_above_imu, 1e-6);
}

TEST(SyntheticDrive, TheOxtsDelayStampsAndSamplesTheRecordsLater)
{
  // As on KITTI raw drives: each OXTS record 13 ms after its frame's scan and image, sampled then.
  SyntheticScenario scenario = smallScenario();
  scenario.oxts_delay_s = 0.013;
  SyntheticDriveOptions options;
  options.output_root = (fs::path(testing::TempDir()) / "synthetic_drive_delay").string();
  options.calibration_dir = kCalibration;
  fs::remove_all(options.output_root);
  const fs::path dir = writeSyntheticDrive(scenario, options).drive_dir;
  const auto nanoseconds = [](const KittiStamp& s) { return s.sec * 1000000000LL + s.nsec; };
  const std::vector<KittiStamp> images = readTimestamps((dir / "image_02/timestamps.txt").string());
  const std::vector<KittiStamp> velo = readTimestamps((dir / "velodyne_points/timestamps.txt").string());
  const std::vector<KittiStamp> oxts = readTimestamps((dir / "oxts/timestamps.txt").string());
  ASSERT_EQ(oxts.size(), 3U);
  for (std::size_t i = 0; i < 3; ++i)
  {
    EXPECT_EQ(nanoseconds(oxts[i]) - nanoseconds(images[i]), 13000000LL) << "frame " << i;
    EXPECT_EQ(nanoseconds(velo[i]), nanoseconds(images[i])) << "frame " << i;
  }
  // The ego at 10 m/s: the first record lies 0.13 m further east than without the delay.
  const OxtsRecord delayed = readOxtsFolder((dir / "oxts").string()).front();
  const OxtsRecord plain = readOxtsFolder((fs::path(drive().summary.drive_dir) / "oxts").string()).front();
  const double scale = mercatorScale(plain.lat);
  const double east = oxtsToMercatorPose(delayed, scale).translation().x() -
                      oxtsToMercatorPose(plain, scale).translation().x();
  EXPECT_NEAR(east, 0.13, 1e-3);

  scenario.oxts_delay_s = 0.05;  // half a frame at 10 Hz
  EXPECT_THROW(scenario.validate(), std::invalid_argument);
  scenario.oxts_delay_s = -0.001;
  EXPECT_THROW(scenario.validate(), std::invalid_argument);
}

TEST(SyntheticDrive, TrackletsAreTheScenarioInTheVelodyneFrame)
{
  const fs::path dir = drive().summary.drive_dir;
  const std::vector<Tracklet> tracklets = readTracklets((dir / "tracklet_labels.xml").string());
  ASSERT_EQ(tracklets.size(), 2U);
  EXPECT_EQ(tracklets[0].object_type, "Car");
  EXPECT_DOUBLE_EQ(tracklets[1].h, 2.2);
  ASSERT_EQ(tracklets[0].poses.size(), 3U);
  // Frame 0: the velodyne is 0.81 m ahead of and 0.32 m right of the IMU at (0, −1.75): the
  // parked car at world (15, −5) is at about (15 − 0.81, −5 + 1.75 + 0.32) in the velodyne frame.
  const TrackletPose& p0 = tracklets[0].poses[0];
  EXPECT_NEAR(p0.tx, 15.0 - 0.8087, 0.05);
  EXPECT_NEAR(p0.ty, -5.0 + 1.75 + 0.3196, 0.05);
  EXPECT_NEAR(p0.tz, -1.73, 0.05);
  // One frame later the ego has moved 1 m: the parked car is 1 m closer.
  EXPECT_NEAR(tracklets[0].poses[1].tx, p0.tx - 1.0, 1e-3);
  // The oncoming van drives at −8 m/s and the ego at +10 m/s: 1.8 m closer per frame, heading back.
  EXPECT_NEAR(tracklets[1].poses[0].tx - tracklets[1].poses[1].tx, 1.8, 1e-3);
  EXPECT_NEAR(std::abs(tracklets[1].poses[0].rz), M_PI, 0.02);
}

TEST(SyntheticDrive, LabelsMatchTheProjectedTracklets)
{
  const fs::path dir = drive().summary.drive_dir;
  const KittiRawCalibration calibration = KittiRawCalibration::readDirectory(kCalibration);
  const std::vector<Tracklet> tracklets = readTracklets((dir / "tracklet_labels.xml").string());
  const std::vector<KittiObjectLabel> labels = readKittiLabels((dir / "label_2/0000000000.txt").string());
  ASSERT_EQ(labels.size(), 2U);
  for (std::size_t i = 0; i < labels.size(); ++i)
  {
    const TrackletPose& pose = tracklets[i].poses[0];
    // The centre of the box (half its height above the bottom) projects inside the 2-D box.
    const Eigen::Vector4d centre(pose.tx, pose.ty, pose.tz + tracklets[i].h / 2.0, 1.0);
    const Eigen::Vector3d pixel = calibration.veloToImage(2) * centre;
    const double u = pixel.x() / pixel.z();
    const double v = pixel.y() / pixel.z();
    const KittiObjectLabel& label = labels[i];
    EXPECT_GT(u, label.left);
    EXPECT_LT(u, label.right);
    EXPECT_GT(v, label.top);
    EXPECT_LT(v, label.bottom);
    EXPECT_EQ(label.type, tracklets[i].object_type);
    EXPECT_NEAR(label.height, tracklets[i].h, 0.01);
    // Location = bottom centre in the rectified camera frame: the camera is 0.27 m ahead of the
    // velodyne (Tr_velo_to_cam), so its depth is the velodyne x − 0.27 m.
    EXPECT_NEAR(label.z, pose.tx - 0.27, 0.05);
  }
  EXPECT_EQ(labels[0].occluded, 0);
  EXPECT_NEAR(labels[0].truncated, 0.0, 1e-6);
}

TEST(SyntheticDrive, LidarSeesTheParkedCar)
{
  const fs::path dir = drive().summary.drive_dir;
  const auto bytes = fs::file_size(dir / "velodyne_points/data/0000000000.bin");
  std::vector<float> points(bytes / sizeof(float));
  std::ifstream in(dir / "velodyne_points/data/0000000000.bin", std::ios::binary);
  in.read(reinterpret_cast<char*>(points.data()), static_cast<std::streamsize>(bytes));
  // Rear face of the parked car: x ≈ 13 − 0.81 m, y ≈ −2.93 ± 0.9 m, above the ground.
  int on_car = 0;
  for (std::size_t i = 0; i + 3 < points.size(); i += 4)
  {
    if (points[i] > 11.5 && points[i] < 13.0 && std::abs(points[i + 1] + 2.93) < 0.8 && points[i + 2] > -1.5)
    {
      ++on_car;
    }
  }
  EXPECT_GT(on_car, 10);
}

TEST(SyntheticDrive, RecordedDriveReplaysTheTracklets)
{
  const std::string recorded = kCalibration + "/2011_09_26_drive_0001_sync";
  const KittiRawCalibration calibration = KittiRawCalibration::readDirectory(kCalibration);
  SyntheticScenario base;
  base.lidar.azimuth_steps = 256;
  const SyntheticScenario scenario = recordedDriveScenario(recorded, calibration, base);
  EXPECT_EQ(scenario.frameCount(), 108);
  ASSERT_EQ(scenario.actors.size(), 15U);
  // The ego follows the OXTS poses: frame 107 at (106.36, −10.03) from the first frame.
  const Pose2D end = scenario.ego.poseAt(scenario.frameTime(107));
  EXPECT_NEAR(end.x, 106.3587853541, 1e-6);
  EXPECT_NEAR(end.y, -10.0295830606, 1e-6);
  // A tracklet exists only while it is labelled.
  const std::vector<Tracklet> recorded_tracklets = readTracklets(recorded + "/tracklet_labels.xml");
  for (std::size_t k = 0; k < recorded_tracklets.size(); ++k)
  {
    const Tracklet& t = recorded_tracklets[k];
    EXPECT_TRUE(scenario.actors[k].activeAt(scenario.frameTime(t.first_frame)));
    EXPECT_FALSE(
        scenario.actors[k].activeAt(scenario.frameTime(t.first_frame + static_cast<int>(t.poses.size()))));
  }

  // Written out and read back, the tracklets come back where they were recorded (the flat
  // world drops the small roll and pitch of the recording: a few centimetres).
  SyntheticDriveOptions options;
  options.output_root = (fs::path(testing::TempDir()) / "recorded_replay").string();
  options.calibration_dir = kCalibration;
  options.max_frames = 2;
  fs::remove_all(options.output_root);
  const SyntheticDriveSummary summary = writeSyntheticDrive(scenario, options);
  const std::vector<Tracklet> replayed = readTracklets(summary.drive_dir + "/tracklet_labels.xml");
  ASSERT_EQ(replayed.size(), 15U);
  std::size_t compared = 0;
  for (std::size_t k = 0; k < replayed.size(); ++k)
  {
    if (recorded_tracklets[k].first_frame != 0)
    {
      continue;
    }
    ASSERT_EQ(replayed[k].first_frame, 0);
    ASSERT_EQ(replayed[k].poses.size(), 2U);
    EXPECT_NEAR(replayed[k].poses[1].tx, recorded_tracklets[k].poses[1].tx, 0.1) << "tracklet " << k;
    EXPECT_NEAR(replayed[k].poses[1].ty, recorded_tracklets[k].poses[1].ty, 0.1) << "tracklet " << k;
    EXPECT_NEAR(std::remainder(replayed[k].poses[1].rz - recorded_tracklets[k].poses[1].rz, 2 * M_PI), 0.0,
                0.02);
    ++compared;
  }
  EXPECT_GE(compared, 3U);
}

TEST(SyntheticDrive, BadOptionsAreNamed)
{
  SyntheticDriveOptions options;
  options.output_root = testing::TempDir();
  options.calibration_dir = "/nonexistent";
  EXPECT_THROW(writeSyntheticDrive(smallScenario(), options), std::runtime_error);
  options.calibration_dir = kCalibration;
  options.drive_number = 10000;
  EXPECT_THROW(options.validate(), std::invalid_argument);
  options.drive_number = 1;
  options.start_time = "yesterday";
  EXPECT_THROW(options.validate(), std::runtime_error);
}

}  // namespace grid_vision_fusion
