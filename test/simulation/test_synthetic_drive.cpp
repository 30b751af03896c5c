// Tests of the synthetic drive writer: the written drive is read back with the KITTI readers and
// checked against the scenario's ground truth and the day's calibration.
#include <gtest/gtest.h>

#include <opencv2/imgcodecs.hpp>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>

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

namespace
{
std::string readText(const fs::path& path)
{
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

/// smallScenario() written to TempDir()/`name` with `change` applied first.
fs::path writeVariant(const std::string& name, const std::function<void(SyntheticScenario&)>& change)
{
  SyntheticScenario scenario = smallScenario();
  change(scenario);
  SyntheticDriveOptions options;
  options.output_root = (fs::path(testing::TempDir()) / name).string();
  options.calibration_dir = kCalibration;
  fs::remove_all(options.output_root);
  return writeSyntheticDrive(scenario, options).drive_dir;
}

/// The file name of frame i without its extension, as the drive writes it.
std::string frameName(std::size_t i)
{
  char name[16];
  std::snprintf(name, sizeof(name), "%010zu", i);
  return name;
}

std::vector<float> readScan(const fs::path& path)
{
  const std::string bytes = readText(path);
  std::vector<float> values(bytes.size() / sizeof(float));
  std::memcpy(values.data(), bytes.data(), values.size() * sizeof(float));
  return values;
}
}  // namespace

TEST(SyntheticDrive, TheDefaultDriveIsWhatItWasBeforeTheRealismKeys)
{
  // Frame 0 of the default drive, written by the code before vehicle profiles, INS errors and
  // the ground's height field existed (commit d2f6139; Debian 12, GCC 12, -O3): its scan's point
  // count and coordinate sums, its OXTS record and its labels. Off by default, none of them may
  // change the drive.
  const SyntheticScenario scenario =
      loadScenario(std::string(GVF_SOURCE_DIR) + "/config/synthetic_drive.yaml");
  SyntheticDriveOptions options;
  options.output_root = (fs::path(testing::TempDir()) / "default_drive").string();
  options.calibration_dir = std::string(GVF_SOURCE_DIR) + "/data/calibration/2011_09_26";
  options.max_frames = 1;
  fs::remove_all(options.output_root);
  const fs::path dir = writeSyntheticDrive(scenario, options).drive_dir;
  const std::vector<float> scan = readScan(dir / "velodyne_points/data/0000000000.bin");
  ASSERT_EQ(scan.size(), 4U * 126228U);
  double sums[4] = {0.0, 0.0, 0.0, 0.0};
  for (std::size_t i = 0; i < scan.size(); ++i)
  {
    sums[i % 4] += scan[i];
  }
  EXPECT_NEAR(sums[0], 46237.99700242374, 1e-3);
  EXPECT_NEAR(sums[1], 81882.77653489355, 1e-3);
  EXPECT_NEAR(sums[2], -159899.14192336798, 1e-3);
  EXPECT_NEAR(sums[3], 59469.302085671574, 1e-3);
  EXPECT_EQ(
      readText(dir / "oxts/data/0000000000.txt"),
      "49.01098427948 8.4237 116.92727594172 0 0 0 0 9 9 0 0 90 0 9.81 90 0 9.81 0 0 0 0 0 0 0.05 0.02 4 10 "
      "6 6 6\n");
  EXPECT_EQ(readText(dir / "label_2/0000000000.txt"),
            "Car 0.00 1 -1.68 663.56 182.79 720.80 224.08 1.50 1.80 4.30 3.16 1.91 28.90 -1.57\n"
            "Car 0.00 1 -1.63 642.21 181.88 670.07 203.65 1.45 1.70 4.10 3.18 2.10 50.90 -1.57\n"
            "Car 0.00 0 1.75 459.18 180.97 504.86 209.30 1.50 1.80 4.40 -7.23 1.97 40.91 1.57\n"
            "Car 0.00 0 -1.55 560.16 184.10 638.39 250.82 1.50 1.80 4.50 -0.30 1.82 18.90 -1.57\n"
            "Car 0.00 3 2.82 825.79 181.46 877.17 197.65 1.50 1.80 4.30 23.00 2.33 68.88 -3.14\n"
            "Car 0.00 2 -1.95 628.40 180.73 665.34 198.49 1.50 1.80 4.30 3.20 2.21 63.90 -1.90\n"
            "Cyclist 0.00 0 -1.65 653.80 176.73 693.43 271.20 1.70 0.60 1.80 1.15 1.78 13.90 -1.57\n");
}

TEST(SyntheticDrive, InsErrorsAreSeededAndSizedAsConfigured)
{
  std::vector<double> times;
  for (int i = 0; i < 4000; ++i)
  {
    times.push_back(0.013 + 0.1 * i);
  }
  InsError model;
  EXPECT_EQ(sampleInsErrors(model, 1, times)[100].east, 0.0) << "disabled: exact";
  model.position_std = 0.02;
  model.yaw_drift_rate = 0.0028;
  model.roll_std = 0.001;
  const std::vector<InsErrorSample> a = sampleInsErrors(model, 1117, times);
  const std::vector<InsErrorSample> same = sampleInsErrors(model, 1117, times);
  const std::vector<InsErrorSample> other = sampleInsErrors(model, 1118, times);
  EXPECT_EQ(a[1234].north, same[1234].north);
  EXPECT_NE(a[1234].north, other[1234].north);
  double east2 = 0.0, north2 = 0.0, roll2 = 0.0, lag = 0.0;
  for (std::size_t k = 0; k < times.size(); ++k)
  {
    east2 += a[k].east * a[k].east;
    north2 += a[k].north * a[k].north;
    roll2 += a[k].roll * a[k].roll;
    lag += k > 0 ? a[k].east * a[k - 1].east : 0.0;
    ASSERT_NEAR(a[k].yaw, 0.0028 * times[k], 1e-12) << "a constant drift, no walk";
    ASSERT_EQ(a[k].up, 0.0);
  }
  const double n = static_cast<double>(times.size());
  EXPECT_NEAR(std::sqrt(east2 / n), 0.02, 0.001);
  EXPECT_NEAR(std::sqrt(north2 / n), 0.02, 0.001);
  EXPECT_NEAR(std::sqrt(roll2 / n), 0.001, 0.00005);
  EXPECT_NEAR(lag / east2, 0.0, 0.05) << "independent from record to record";
  EXPECT_NEAR(a[50].yaw * 180.0 / M_PI, 0.8, 0.01) << "0.8 deg after 5 s";
  // Correlated over 1 s: the same stationary std, consecutive records (0.1 s) correlate by e^-0.1.
  model.position_correlation_s = 1.0;
  model.yaw_drift_rate = 0.0;
  model.yaw_walk_std = 0.002;
  const std::vector<InsErrorSample> c = sampleInsErrors(model, 1117, times);
  double c2 = 0.0, clag = 0.0, step2 = 0.0;
  for (std::size_t k = 1; k < times.size(); ++k)
  {
    c2 += c[k].east * c[k].east;
    clag += c[k].east * c[k - 1].east;
    step2 += (c[k].yaw - c[k - 1].yaw) * (c[k].yaw - c[k - 1].yaw);
  }
  EXPECT_NEAR(std::sqrt(c2 / n), 0.02, 0.003);
  EXPECT_NEAR(clag / c2, std::exp(-0.1), 0.02);
  EXPECT_NEAR(std::sqrt(step2 / n), 0.002 * std::sqrt(0.1), 0.0001) << "random walk steps";
  EXPECT_EQ(c[0].yaw, 0.0);
}

TEST(SyntheticDrive, AnInsErrorChangesTheOxtsOnly)
{
  const fs::path exact = drive().summary.drive_dir;
  InsError model;
  model.position_std = 0.03;
  model.yaw_drift_rate = 0.01;
  model.roll_std = 0.002;
  const fs::path noisy =
      writeVariant("synthetic_drive_ins", [&](SyntheticScenario& s) { s.ins_error = model; });
  const std::vector<OxtsRecord> truth = readOxtsFolder((exact / "oxts").string());
  const std::vector<OxtsRecord> reported = readOxtsFolder((noisy / "oxts").string());
  const std::vector<InsErrorSample> errors = sampleInsErrors(model, smallScenario().seed, {0.0, 0.1, 0.2});
  ASSERT_EQ(reported.size(), 3U);
  const double scale = mercatorScale(truth[0].lat);
  for (std::size_t i = 0; i < 3; ++i)
  {
    const std::string frame = frameName(i);
    EXPECT_EQ(readText(exact / "velodyne_points/data" / (frame + ".bin")),
              readText(noisy / "velodyne_points/data" / (frame + ".bin")))
        << "the lidar sees the true pose";
    EXPECT_EQ(readText(exact / "label_2" / (frame + ".txt")), readText(noisy / "label_2" / (frame + ".txt")));
    const Eigen::Vector3d offset = oxtsToMercatorPose(reported[i], scale).translation() -
                                   oxtsToMercatorPose(truth[i], scale).translation();
    EXPECT_NEAR(offset.x(), errors[i].east, 1e-6);
    EXPECT_NEAR(offset.y(), errors[i].north, 1e-6);
    EXPECT_NEAR(reported[i].yaw - truth[i].yaw, 0.01 * 0.1 * static_cast<double>(i), 1e-12);
    EXPECT_NEAR(reported[i].roll, errors[i].roll, 1e-12);
  }
  EXPECT_EQ(readText(exact / "tracklet_labels.xml"), readText(noisy / "tracklet_labels.xml"));
}

TEST(SyntheticDrive, TheEgoAndTheActorsStandOnACamberedRoad)
{
  // The ego at y = −1.75 on the right half of a road cambered by 3 %: it rolls left side up by
  // atan(0.03); the parked car at y = −5 stands on the same plane, so in the velodyne frame its
  // bottom is as far below the sensor as the ground under the ego (1.73 m); the road's left half,
  // beyond the crown, lies lower in the scan.
  const fs::path dir = writeVariant("synthetic_drive_camber",
                                    [](SyntheticScenario& s)
                                    {
                                      s.ground.camber = 0.03;
                                      s.ground.kerb_height = 0.15;
                                      s.ground.verge_rise_right = 0.4;
                                    });
  const std::vector<OxtsRecord> records = readOxtsFolder((dir / "oxts").string());
  EXPECT_NEAR(records[0].roll, std::atan(0.03), 1e-9);
  EXPECT_NEAR(records[0].pitch, 0.0, 1e-12);
  // The IMU 0.93 m above the ground's mean height under the wheels (−3 % · 1.75 m), tilted.
  EXPECT_NEAR(records[0].alt - 116.0, -0.03 * 1.75 + (1.73 - 0.80) * std::cos(std::atan(0.03)), 0.02);
  const std::vector<Tracklet> tracklets = readTracklets((dir / "tracklet_labels.xml").string());
  EXPECT_NEAR(tracklets[0].poses[0].tz, -1.73, 0.05);
  // Scan, against the flat world's (the velodyne is turned against the IMU by 0.85° in roll, so
  // that flat ground is not level in its frame): the ground 4 m right of the sensor, on the
  // ego's plane, where it was; 6 m left of it, 3.9 m beyond the crown, 2 · 3 % · 3.9 m lower.
  const auto meanGroundZ = [](const fs::path& scan_path, double y_min, double y_max)
  {
    const std::vector<float> scan = readScan(scan_path);
    double sum = 0.0;
    int count = 0;
    for (std::size_t i = 0; i + 3 < scan.size(); i += 4)
    {
      if (scan[i] > -3.0 && scan[i] < 3.0 && scan[i + 1] > y_min && scan[i + 1] < y_max)
      {
        sum += scan[i + 2];
        ++count;
      }
    }
    EXPECT_GT(count, 10);
    return sum / std::max(count, 1);
  };
  const fs::path scan = dir / "velodyne_points/data/0000000000.bin";
  const fs::path flat = fs::path(drive().summary.drive_dir) / "velodyne_points/data/0000000000.bin";
  EXPECT_NEAR(meanGroundZ(scan, -4.2, -3.8) - meanGroundZ(flat, -4.2, -3.8), 0.0, 0.01);
  EXPECT_NEAR(meanGroundZ(scan, 5.8, 6.2) - meanGroundZ(flat, 5.8, 6.2), -2.0 * 0.03 * 3.9, 0.02);
}

TEST(SyntheticDrive, VehicleProfilesKeepTheLabelBoxes)
{
  // The same drive with car and van profiles: the labels (class, size, place, heading, 2-D box)
  // and the tracklets are the boxes', as before; the scan differs.
  const fs::path boxes = drive().summary.drive_dir;
  const fs::path profiles = writeVariant("synthetic_drive_profiles",
                                         [](SyntheticScenario& s)
                                         {
                                           s.actors[0].shape = VehicleShape::kCar;
                                           s.actors[1].shape = VehicleShape::kVan;
                                         });
  for (int frame = 0; frame < 3; ++frame)
  {
    const std::string name = frameName(static_cast<std::size_t>(frame)) + ".txt";
    const std::vector<KittiObjectLabel> a = readKittiLabels((boxes / "label_2" / name).string());
    const std::vector<KittiObjectLabel> b = readKittiLabels((profiles / "label_2" / name).string());
    ASSERT_EQ(a.size(), b.size());
    for (std::size_t i = 0; i < a.size(); ++i)
    {
      EXPECT_EQ(a[i].type, b[i].type);
      EXPECT_EQ(a[i].left, b[i].left);
      EXPECT_EQ(a[i].bottom, b[i].bottom);
      EXPECT_EQ(a[i].length, b[i].length);
      EXPECT_EQ(a[i].x, b[i].x);
      EXPECT_EQ(a[i].z, b[i].z);
      EXPECT_EQ(a[i].rotation_y, b[i].rotation_y);
    }
  }
  const std::vector<Tracklet> a = readTracklets((boxes / "tracklet_labels.xml").string());
  const std::vector<Tracklet> b = readTracklets((profiles / "tracklet_labels.xml").string());
  ASSERT_EQ(a.size(), b.size());
  EXPECT_EQ(a[0].poses[2].tx, b[0].poses[2].tx);
  EXPECT_NE(readText(boxes / "velodyne_points/data/0000000000.bin"),
            readText(profiles / "velodyne_points/data/0000000000.bin"));
}

}  // namespace grid_vision_fusion
