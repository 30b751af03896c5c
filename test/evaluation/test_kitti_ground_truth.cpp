// Tests of the KITTI ground truth on the real metadata of drive 2011_09_26_0001 (test/data,
// KITTI CC BY-NC-SA 3.0, see test/data/kitti_raw_2011_09_26/README.md) and of the label files
// with a motion column on files written by the tests.
//
// Reference numbers come from an independent numpy transcription (written for these tests, not
// sharing code with the package): calibration parsed from the text files, M = P_rect_02 ·
// R_rect_00 · [R|T]_velo_to_cam, the 8 corners of the tracklet box, edges clipped at w = 0.1,
// min/max of u = x/w, v = y/w; OXTS poses with the devkit's convertOxtsToPose relative to the
// first record; world = T_oxts(i) · inv([R|T]_imu_to_velo) · (tx, ty, tz + h/2); velocity
// (p[hi] − p[lo]) / (t[hi] − t[lo]) with lo = max(0, j − 2), hi = min(n − 1, j + 2) and t from
// image_02/timestamps.txt.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>

#include "grid_vision_fusion/evaluation/kitti_ground_truth.h"

namespace grid_vision_fusion
{
namespace
{
const std::string kData = std::string(GVF_TEST_DATA_DIR) + "/kitti_raw_2011_09_26";
const std::string kDrive = kData + "/2011_09_26_drive_0001_sync";

const KittiDrive& drive()
{
  static const KittiDrive d = KittiDrive::read(kDrive, "", true);
  return d;
}

const std::vector<GroundTruthObject>& groundTruth()
{
  static const std::vector<GroundTruthObject> gt = trackletGroundTruth(drive(), KittiGroundTruthConfig{});
  return gt;
}

const GroundTruthObject* find(int tracklet, int frame)
{
  for (const GroundTruthObject& g : groundTruth())
  {
    if (g.tracklet == tracklet && g.frame_index == frame)
    {
      return &g;
    }
  }
  return nullptr;
}

template <typename F>
std::string errorOf(F&& f)
{
  try
  {
    f();
  }
  catch (const std::exception& e)
  {
    return e.what();
  }
  return "";
}

std::string tempDir(const std::string& name)
{
  const std::string dir = testing::TempDir() + "gvf_gt_" + name;
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}
}  // namespace

TEST(KittiGroundTruth, ReadsTheDrive)
{
  EXPECT_EQ(drive().frameCount(), 108);
  EXPECT_EQ(drive().tracklets.size(), 15U);
  EXPECT_TRUE(drive().world_from_imu[0].isApprox(Eigen::Isometry3d::Identity(), 1e-9));
  EXPECT_EQ(drive().calibration.image_size[2][0], 1242U);
}

TEST(KittiGroundTruth, FirstCarBoxInFrameZeroMatchesAnIndependentProjection)
{
  // Tracklet 0, pose 0: Car tx 25.21 ty 8.60 tz −1.79 rz −3.184, h 2.167 w 1.706 l 4.329.
  // numpy: u 309.55..407.47, v 168.82..238.01, fully in the image.
  const GroundTruthObject* g = find(0, 0);
  ASSERT_NE(g, nullptr);
  EXPECT_EQ(g->object.label, "car");
  EXPECT_EQ(g->object.frame, "0000000000");
  EXPECT_NEAR(g->object.box.x_min, 309.55, 1.0);
  EXPECT_NEAR(g->object.box.y_min, 168.82, 1.0);
  EXPECT_NEAR(g->object.box.x_max, 407.47, 1.0);
  EXPECT_NEAR(g->object.box.y_max, 238.01, 1.0);
  EXPECT_NEAR(g->truncation, 0.0, 1e-9);
  EXPECT_FALSE(g->object.difficult);
  // Longitudinal distance = x of the box centre in the velodyne frame = tx.
  EXPECT_NEAR(g->object.longitudinal_m, 25.2125, 1e-3);
  // Frame 0 is the world origin: world = inv(velo_from_imu) · centre; numpy (26.0148, 8.3039).
  ASSERT_TRUE(g->object.has_state);
  EXPECT_NEAR(g->object.x, 26.0148, 1e-3);
  EXPECT_NEAR(g->object.y, 8.3039, 1e-3);
}

TEST(KittiGroundTruth, ProjectsAPointTheWayTheDesignSays)
{
  // KITTI check values of the 2011_09_26 calibration, camera 2: velodyne (10, 0, −1.73) → (615.3, 303.5). A
  // 0.02 m box around that point projects to a box of about 1.5 px around it.
  BoundingBox box;
  double truncation = 1.0;
  ASSERT_TRUE(projectVeloBox(drive().calibration, 2, Eigen::Vector3d(10.0, 0.0, -1.74), 0.0, 0.02, 0.02, 0.02,
                             0.1, box, truncation));
  EXPECT_NEAR((box.x_min + box.x_max) / 2.0, 615.3, 0.3);
  EXPECT_NEAR((box.y_min + box.y_max) / 2.0, 303.5, 0.3);
  EXPECT_LT(box.x_max - box.x_min, 2.0);
  // Behind the camera: nothing.
  EXPECT_FALSE(projectVeloBox(drive().calibration, 2, Eigen::Vector3d(-10.0, 0.0, -1.7), 0.0, 4.0, 1.8, 1.5,
                              0.1, box, truncation));
  // Far to the side (90° left at 2 m ahead): outside the image.
  EXPECT_FALSE(projectVeloBox(drive().calibration, 2, Eigen::Vector3d(2.0, 30.0, -1.7), 0.0, 4.0, 1.8, 1.5,
                              0.1, box, truncation));
}

TEST(KittiGroundTruth, BoxStraddlingTheCameraIsClippedAtTheNearPlane)
{
  // A 10 m long box from 5 m behind to 5 m ahead of the sensor, 3 m to the left: its projected
  // box runs to the left image edge (clipped) and the truncation is large.
  BoundingBox box;
  double truncation = 0.0;
  ASSERT_TRUE(projectVeloBox(drive().calibration, 2, Eigen::Vector3d(0.0, 3.0, -1.7), 0.0, 10.0, 1.8, 1.5,
                             0.1, box, truncation));
  EXPECT_FLOAT_EQ(box.x_min, 0.F);
  EXPECT_GE(box.x_max, 0.F);
  EXPECT_LE(box.x_max, 1241.F);
  EXPECT_LE(box.y_max, 374.F);
  EXPECT_GT(truncation, 0.5);
}

TEST(KittiGroundTruth, WorldSpeedFromPlusMinusTwoFrames)
{
  // Tram (tracklet 3, frames 0..107). numpy: j = 0 one-sided over frames 0..2 → 10.1168 m/s;
  // j = 10 central over 8..12 → 9.5116 m/s; j = 107 one-sided over 105..107 → 9.1213 m/s.
  const GroundTruthObject* first = find(3, 0);
  const GroundTruthObject* middle = find(3, 10);
  const GroundTruthObject* last = find(3, 107);
  ASSERT_NE(first, nullptr);
  ASSERT_NE(middle, nullptr);
  ASSERT_NE(last, nullptr);
  EXPECT_EQ(middle->object.label, "tram");
  EXPECT_NEAR(first->speed_mps, 10.1168, 1e-3);
  EXPECT_NEAR(middle->speed_mps, 9.5116, 1e-3);
  EXPECT_NEAR(middle->object.vx, 9.4460, 1e-3);
  EXPECT_NEAR(middle->object.vy, -1.1153, 1e-3);
  EXPECT_NEAR(last->speed_mps, 9.1213, 1e-3);
  EXPECT_EQ(middle->object.motion, Motion::kDynamic);
  // Cyclist (tracklet 10, first frame 33), pose 5 = frame 38: numpy 5.2747 m/s.
  const GroundTruthObject* cyclist = find(10, 38);
  ASSERT_NE(cyclist, nullptr);
  EXPECT_EQ(cyclist->object.label, "cyclist");
  EXPECT_NEAR(cyclist->speed_mps, 5.2747, 1e-3);
}

TEST(KittiGroundTruth, ParkedCarsAreStaticMovingObjectsDynamic)
{
  // The ego vehicle drives at ~13 m/s (OXTS vf of frame 0: 13.17 m/s), so a parked car comes
  // ~18 m closer in the velodyne frame over 14 frames while its world position stays within a
  // few centimetres. numpy, over the whole tracklet: world displacement of tracklets 0, 1, 2, 6,
  // 7, 8, 9, 13, 14 ≤ 0.39 m and their ±2-frame speed ≤ 0.47 m/s in every frame; the tram (3) and
  // the cyclists (10, 11) move 99 m, 40 m and 16 m at 8.0..10.1, 4.9..5.6 and 4.0..4.8 m/s.
  const Tracklet& parked = drive().tracklets[0];
  EXPECT_GT(parked.poses.front().tx - parked.poses.back().tx, 15.0);

  const std::set<int> parked_ids{0, 1, 2, 6, 7, 8, 9, 13, 14};
  const std::set<int> moving_ids{3, 10, 11};
  std::map<int, int> seen;
  for (const GroundTruthObject& g : groundTruth())
  {
    ++seen[g.tracklet];
    if (parked_ids.count(g.tracklet))
    {
      EXPECT_EQ(g.object.motion, Motion::kStatic) << "tracklet " << g.tracklet << " frame " << g.frame_index;
      EXPECT_LT(g.speed_mps, 0.5);
    }
    if (moving_ids.count(g.tracklet))
    {
      EXPECT_EQ(g.object.motion, Motion::kDynamic) << "tracklet " << g.tracklet << " frame " << g.frame_index;
      EXPECT_GT(g.speed_mps, 3.5);
    }
  }
  for (int id : {0, 3, 10, 11, 13})
  {
    EXPECT_GT(seen[id], 5) << "tracklet " << id;
  }
  // A higher threshold turns the cyclists static, the tram stays dynamic.
  KittiGroundTruthConfig config;
  config.dynamic_speed_mps = 6.0;
  for (const GroundTruthObject& g : trackletGroundTruth(drive(), config))
  {
    if (g.tracklet == 10 || g.tracklet == 11)
    {
      EXPECT_EQ(g.object.motion, Motion::kStatic);
    }
    if (g.tracklet == 3)
    {
      EXPECT_EQ(g.object.motion, Motion::kDynamic);
    }
  }
}

TEST(KittiGroundTruth, DifficultFlags)
{
  // numpy: tracklet 2 in frame 25 is cut by the left image edge, truncation 0.639 (flags: not
  // occluded, truncation flag 1) → difficult by the projected truncation.
  const GroundTruthObject* cut = find(2, 25);
  ASSERT_NE(cut, nullptr);
  EXPECT_NEAR(cut->truncation, 0.639, 0.01);
  EXPECT_FLOAT_EQ(cut->object.box.x_min, 0.F);
  EXPECT_NEAR(cut->object.box.x_max, 136.7, 1.0);
  EXPECT_TRUE(cut->object.difficult);
  // Tracklet 5 in frame 8: occlusion flag 2, fully in the image → difficult.
  const GroundTruthObject* occluded = find(5, 8);
  ASSERT_NE(occluded, nullptr);
  EXPECT_EQ(drive().tracklets[5].poses[0].occlusion, 2);
  EXPECT_NEAR(occluded->truncation, 0.0, 1e-9);
  EXPECT_TRUE(occluded->object.difficult);
  // Tracklet 0 in frame 13: truncation flag 2 (leaving the image) → difficult.
  const GroundTruthObject* leaving = find(0, 13);
  ASSERT_NE(leaving, nullptr);
  EXPECT_EQ(drive().tracklets[0].poses[13].truncation, 2);
  EXPECT_TRUE(leaving->object.difficult);

  // With the thresholds relaxed, the cut box is no longer difficult; the occluded one is.
  KittiGroundTruthConfig relaxed;
  relaxed.max_truncation = 0.7;
  const std::vector<GroundTruthObject> gt = trackletGroundTruth(drive(), relaxed);
  for (const GroundTruthObject& g : gt)
  {
    if (g.tracklet == 2 && g.frame_index == 25)
    {
      EXPECT_FALSE(g.object.difficult);
    }
    if (g.tracklet == 5 && g.frame_index == 8)
    {
      EXPECT_TRUE(g.object.difficult);
    }
  }
}

TEST(KittiGroundTruth, ClassMapRenamesAndDrops)
{
  KittiGroundTruthConfig config;
  config.class_map = {{"tram", ""}, {"cyclist", "bike"}};
  EXPECT_EQ(config.labelOf("Car"), "car");
  EXPECT_EQ(config.labelOf("Tram"), "");
  EXPECT_EQ(config.labelOf("Cyclist"), "bike");
  config.keep_unmapped = false;
  EXPECT_EQ(config.labelOf("Car"), "");
  std::set<std::string> labels;
  for (const GroundTruthObject& g : trackletGroundTruth(drive(), config))
  {
    labels.insert(g.object.label);
  }
  EXPECT_EQ(labels, (std::set<std::string>{"bike"}));
}

TEST(KittiGroundTruth, ConfigValidation)
{
  KittiGroundTruthConfig config;
  EXPECT_NO_THROW(config.validate());
  config.dynamic_speed_mps = -1.0;
  EXPECT_NE(errorOf([&] { config.validate(); }).find("dynamic_speed_mps"), std::string::npos);
  config = KittiGroundTruthConfig{};
  config.speed_half_window = 0;
  EXPECT_NE(errorOf([&] { config.validate(); }).find("speed_half_window"), std::string::npos);
  config = KittiGroundTruthConfig{};
  config.speed_window_s = 0.0;
  EXPECT_NE(errorOf([&] { config.validate(); }).find("speed_window_s"), std::string::npos);
  config = KittiGroundTruthConfig{};
  config.camera = 4;
  EXPECT_NE(errorOf([&] { config.validate(); }).find("camera"), std::string::npos);
  config = KittiGroundTruthConfig{};
  config.near_plane_m = 0.0;
  EXPECT_NE(errorOf([&] { config.validate(); }).find("near_plane_m"), std::string::npos);
}

TEST(KittiGroundTruth, TrackletBeyondTheDriveIsAnError)
{
  KittiDrive d = drive();
  d.tracklets[0].first_frame = 100;  // 14 poses: frames 100..113 of a 108-frame drive
  EXPECT_NE(errorOf([&] { trackletGroundTruth(d, KittiGroundTruthConfig{}); }).find("tracklet 0"),
            std::string::npos);
}

TEST(KittiGroundTruth, MissingDriveFilesAreNamed)
{
  const std::string dir = tempDir("missing");
  EXPECT_NE(errorOf([&] { KittiDrive::read(dir, kData, true); }).find(dir + "/image_02/timestamps.txt"),
            std::string::npos);
}

TEST(TrajectoryVelocity, CentralInsideOneSidedAtTheEnds)
{
  // x = t² sampled at t = 0..5: central ±2 differences at j = 2: (16 − 0)/4 = 4 = 2t exactly.
  std::vector<Eigen::Vector3d> p;
  std::vector<double> t;
  for (int i = 0; i <= 5; ++i)
  {
    t.push_back(i);
    p.emplace_back(i * i, 0.0, 0.0);
  }
  EXPECT_DOUBLE_EQ(trajectoryVelocity(p, t, 2, 2).x(), 4.0);
  EXPECT_DOUBLE_EQ(trajectoryVelocity(p, t, 0, 2).x(), 2.0);  // (4 − 0) / 2
  EXPECT_DOUBLE_EQ(trajectoryVelocity(p, t, 5, 2).x(), 8.0);  // over 3..5: (25 − 9) / 2
  EXPECT_DOUBLE_EQ(trajectoryVelocity(p, t, 1, 1).x(), 2.0);  // (4 − 0) / 2
  EXPECT_TRUE(trajectoryVelocity({p[0]}, {0.0}, 0, 2).isZero());
  EXPECT_THROW(trajectoryVelocity(p, std::vector<double>(6, 1.0), 2, 2), std::invalid_argument);
}

TEST(NearestFrame, WithinTheTolerance)
{
  const std::vector<double> times{10.0, 10.1, 10.2};
  EXPECT_EQ(nearestFrame(times, 10.0, 0.05), 0);
  EXPECT_EQ(nearestFrame(times, 10.13, 0.05), 1);
  EXPECT_EQ(nearestFrame(times, 10.17, 0.05), 2);
  EXPECT_EQ(nearestFrame(times, 9.9, 0.05), -1);
  EXPECT_EQ(nearestFrame(times, 10.3, 0.05), -1);
  EXPECT_EQ(nearestFrame(times, std::nan(""), 0.05), -1);
  EXPECT_EQ(nearestFrame({}, 10.0, 0.05), -1);
}

TEST(MotionLabels, ParsesTheMotionColumnWithAndWithoutScore)
{
  std::istringstream in(
      "Car 0.00 0 -1.58 587.0 173.3 614.1 200.1 1.65 1.67 3.64 -0.65 1.71 46.70 -1.59 dynamic\n"
      "\n"
      "Van 0.10 1 1.0 10 20 30 40 2.0 1.8 4.5 1.0 1.6 20.0 0.1 0.87 static\n");
  const std::vector<MotionLabel> labels = parseMotionLabels(in, "frame.txt");
  ASSERT_EQ(labels.size(), 2U);
  EXPECT_EQ(labels[0].label.type, "Car");
  EXPECT_EQ(labels[0].motion, Motion::kDynamic);
  EXPECT_FALSE(labels[0].label.score.has_value());
  EXPECT_FLOAT_EQ(labels[0].label.right, 614.1F);
  EXPECT_EQ(labels[1].motion, Motion::kStatic);
  ASSERT_TRUE(labels[1].label.score.has_value());
  EXPECT_FLOAT_EQ(*labels[1].label.score, 0.87F);
}

TEST(MotionLabels, MalformedLinesNameFileAndLine)
{
  auto error = [](const std::string& text)
  {
    std::istringstream in(text);
    return errorOf([&] { parseMotionLabels(in, "labels/000007.txt"); });
  };
  const std::string good = "Car 0 0 0 1 2 3 4 1.5 1.6 3.9 0 1.7 20 0 static\n";
  // No motion column: 15 fields.
  EXPECT_NE(error(good + "\nCar 0 0 0 1 2 3 4 1.5 1.6 3.9 0 1.7 20 0\n").find("labels/000007.txt:3:"),
            std::string::npos);
  // Unknown motion word.
  const std::string moving = error("Car 0 0 0 1 2 3 4 1.5 1.6 3.9 0 1.7 20 0 moving\n");
  EXPECT_NE(moving.find("labels/000007.txt:1:"), std::string::npos);
  EXPECT_NE(moving.find("'moving'"), std::string::npos);
  // A bad number, after a blank line: the KITTI reader reports the right line.
  const std::string bad = error(good + "\n\nCar 0 0 0 1 2 x 4 1.5 1.6 3.9 0 1.7 20 0 dynamic\n");
  EXPECT_NE(bad.find("labels/000007.txt:4:"), std::string::npos) << bad;
  // A missing file is named.
  EXPECT_NE(errorOf([] { readMotionLabels("/nonexistent/000001.txt"); }).find("/nonexistent/000001.txt"),
            std::string::npos);
}

TEST(MotionLabels, FolderGroundTruth)
{
  const std::string dir = tempDir("labels");
  // Frame 42: a car 20 m ahead (camera z = 20) dynamic, a heavily occluded van, a DontCare.
  std::ofstream(dir + "/000042.txt")
      << "Car 0.00 0 0 100 150 200 220 1.5 1.6 3.9 0.0 1.65 20.0 0 dynamic\n"
         "Van 0.00 2 0 300 150 400 230 2.0 1.8 4.5 2.0 1.65 25.0 0 static\n"
         "DontCare -1 -1 -10 500 150 540 170 -1 -1 -1 -1000 -1000 -1000 -10 static\n";
  // Frame 7: truncated over the threshold, box partly outside the image (clipped).
  std::ofstream(dir + "/7.txt") << "Car 0.80 0 0 -20 150 80 250 1.5 1.6 3.9 -8.0 1.65 10.0 0 static\n";
  std::ofstream(dir + "/notes.txt") << "not a label file\n";
  const std::vector<GroundTruthObject> gt =
      labelFolderGroundTruth(dir, drive().calibration, KittiGroundTruthConfig{});
  ASSERT_EQ(gt.size(), 3U);
  EXPECT_EQ(gt[0].object.frame, "0000000007");
  EXPECT_TRUE(gt[0].object.difficult);
  EXPECT_FLOAT_EQ(gt[0].object.box.x_min, 0.F);
  EXPECT_EQ(gt[0].object.motion, Motion::kStatic);
  EXPECT_EQ(gt[1].object.frame, "0000000042");
  EXPECT_EQ(gt[1].object.label, "car");
  EXPECT_EQ(gt[1].object.motion, Motion::kDynamic);
  EXPECT_FALSE(gt[1].object.difficult);
  EXPECT_FALSE(gt[1].object.has_state);
  // Camera z = 20 m; the velodyne is 0.27 m behind camera 0 (calib_velo_to_cam T_z = −0.27):
  // x_velo ≈ 20.27.
  EXPECT_NEAR(gt[1].object.longitudinal_m, 20.27, 0.05);
  EXPECT_EQ(gt[2].object.label, "van");
  EXPECT_TRUE(gt[2].object.difficult);

  // A malformed file is named with its line.
  std::ofstream(dir + "/000043.txt") << "Car 0 0 0 1 2 3 4 1.5 1.6 3.9 0 1.7 20 0 fast\n";
  EXPECT_NE(errorOf([&] { labelFolderGroundTruth(dir, drive().calibration, KittiGroundTruthConfig{}); })
                .find("000043.txt:1:"),
            std::string::npos);
  EXPECT_NE(
      errorOf([&] { labelFolderGroundTruth(dir + "/none", drive().calibration, KittiGroundTruthConfig{}); })
          .find(dir + "/none"),
      std::string::npos);
}

TEST(MotionLabels, FolderOfTenDigitNames)
{
  // The raw layout's names (0000000012.txt, as label_2 of an assembled drive) are frame indices
  // too; a longer run of digits is no frame name.
  const std::string dir = tempDir("ten_digits");
  std::ofstream(dir + "/0000000012.txt")
      << "Car 0.00 0 0 100 150 200 220 1.5 1.6 3.9 0.0 1.65 20.0 0 static\n";
  std::ofstream(dir + "/12345678901.txt") << "not a label file\n";
  const std::vector<GroundTruthObject> gt =
      labelFolderGroundTruth(dir, drive().calibration, KittiGroundTruthConfig{});
  ASSERT_EQ(gt.size(), 1U);
  EXPECT_EQ(gt[0].frame_index, 12);
  EXPECT_EQ(gt[0].object.frame, "0000000012");
}

TEST(KittiFrameName, TenDigits)
{
  EXPECT_EQ(kittiFrameName(42), "0000000042");
  EXPECT_THROW(kittiFrameName(-1), std::invalid_argument);
}

}  // namespace grid_vision_fusion
