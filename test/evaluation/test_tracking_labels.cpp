// Tests of the ground truth from KITTI tracking labels (label_02/NNNN.txt) on a synthetic drive
// built here: the parser (good lines, DontCare, malformed lines named by file and line), the
// world positions against a case computed by hand, the motion fitted over a second of each
// track (a parked car with injected jitter stays static, a car at 6 m/s is dynamic, short
// tracks have no motion), the track ids as the tracking metrics' identities and the DontCare
// regions.
//
// The synthetic drive: frames 0.1 s apart; the ego drives along the world x axis at 10 m/s
// (world ← IMU of frame i = translation (i m, 0, 0)); the velodyne sits at (0.8, −0.3, 0.8) m in
// the IMU frame (velo_from_imu translation (−0.8, 0.3, −0.8)); camera 0 looks along the
// velodyne x axis with its origin at (0.3, 0, −0.1) m in the velodyne frame (cam = R · velo + T,
// R: cam x = −velo y, cam y = −velo z, cam z = velo x; T = (0, −0.1, −0.3)); no rectifying
// rotation; P_rect: f = 700 px, principal point (600, 180), images 1242 × 375.
#include <gtest/gtest.h>

#include <sys/wait.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>

#include "grid_vision_fusion/evaluation/kitti_ground_truth.h"

namespace grid_vision_fusion
{
namespace
{
constexpr double kFrameTime = 0.1;  // [s]

/// The synthetic drive; its OXTS positions drift sideways by `drift` per frame (the ego does not).
KittiDrive syntheticDrive(int frames, double drift = 0.0)
{
  KittiDrive drive;
  for (int i = 0; i < frames; ++i)
  {
    drive.stamps.push_back({1000 + i / 10, static_cast<std::uint32_t>((i % 10) * 100000000)});
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
    pose.translation() = Eigen::Vector3d(10.0 * kFrameTime * i, drift * i, 0.0);
    drive.world_from_imu.push_back(pose);
  }
  drive.odom_from_imu = alongHeadingPoses(drive.world_from_imu);  // as KittiDrive::read()
  KittiRawCalibration& c = drive.calibration;
  for (std::size_t k = 0; k < 4; ++k)
  {
    c.p_rect[k] << 700.0, 0.0, 600.0, 0.0, 0.0, 700.0, 180.0, 0.0, 0.0, 0.0, 1.0, 0.0;
    c.r_rect[k].setIdentity();
    c.image_size[k] = {1242, 375};
  }
  c.cam0_from_velo.linear() << 0.0, -1.0, 0.0, 0.0, 0.0, -1.0, 1.0, 0.0, 0.0;
  c.cam0_from_velo.translation() = Eigen::Vector3d(0.0, -0.1, -0.3);
  c.velo_from_imu.translation() = Eigen::Vector3d(-0.8, 0.3, -0.8);
  return drive;
}

/// A tracking label line: a car whose bottom centre is at (x, 1.65, z) in the camera frame,
/// facing along the camera z axis (rotation_y −π/2), 1.5 m high, 1.6 m wide, 4 m long.
std::string carLine(int frame, int track, double x, double z, const std::string& box = "500 150 700 250",
                    int truncated = 0, int occluded = 0)
{
  char line[256];
  std::snprintf(line, sizeof(line), "%d %d Car %d %d -1.57 %s 1.5 1.6 4.0 %.4f 1.65 %.4f -1.5707963\n", frame,
                track, truncated, occluded, box.c_str(), x, z);
  return line;
}

std::vector<TrackingLabel> parse(const std::string& text, const std::string& name = "0001.txt")
{
  std::istringstream in(text);
  return parseTrackingLabels(in, name);
}

std::string errorOf(const std::string& text)
{
  try
  {
    parse(text, "label_02/0001.txt");
  }
  catch (const KittiLabelError& e)
  {
    return e.what();
  }
  return "";
}

const GroundTruthObject* find(const TrackingGroundTruth& truth, int track, int frame)
{
  for (const GroundTruthObject& g : truth.objects)
  {
    if (!g.object.dont_care && g.tracklet == track && g.frame_index == frame)
    {
      return &g;
    }
  }
  return nullptr;
}
}  // namespace

TEST(TrackingLabels, ParsesObjectsDontCareAndScores)
{
  const std::vector<TrackingLabel> labels = parse(
      "0 -1 DontCare -1 -1 -10.000000 356.4 195.81 374.1 216.65 -1000 -1000 -1000 -10 -1 -1 -1\n"
      "\n"
      "0 0 Car 0 0 -1.983535 776.29 167.35 1241.0 374.0 1.509920 1.85 4.930564 2.921483 1.510843 6.348542 "
      "-1.570796\n"
      "3 12 Pedestrian 1 3 0.5 10 20 30 80 1.7 0.6 0.8 -3.0 1.7 12.0 0.2 0.93\n");
  ASSERT_EQ(labels.size(), 3U);
  EXPECT_TRUE(labels[0].dontCare());
  EXPECT_EQ(labels[0].track_id, -1);
  EXPECT_EQ(labels[0].line, 1U);
  EXPECT_FLOAT_EQ(labels[0].object.right, 374.1F);
  EXPECT_FALSE(labels[1].dontCare());
  EXPECT_EQ(labels[1].frame, 0);
  EXPECT_EQ(labels[1].track_id, 0);
  EXPECT_EQ(labels[1].line, 3U);
  EXPECT_EQ(labels[1].object.type, "Car");
  EXPECT_FLOAT_EQ(labels[1].object.z, 6.348542F);
  EXPECT_FALSE(labels[1].object.score.has_value());
  EXPECT_EQ(labels[2].frame, 3);
  EXPECT_EQ(labels[2].track_id, 12);
  EXPECT_FLOAT_EQ(labels[2].object.truncated, 1.F);
  EXPECT_EQ(labels[2].object.occluded, 3);
  ASSERT_TRUE(labels[2].object.score.has_value());
  EXPECT_FLOAT_EQ(*labels[2].object.score, 0.93F);
}

TEST(TrackingLabels, MalformedLinesNameFileAndLine)
{
  const std::string good = carLine(0, 1, 2.0, 20.0);
  struct Case
  {
    std::string text;
    std::string message;
  };
  const std::vector<Case> cases{
      {good + "0 2 Car 0 0 -1.57 500 150 700 250 1.5 1.6 4.0 2 1.65\n",
       "label_02/0001.txt:2: expected 17 fields"},
      {good + "\n\nx 2 Car 0 0 -1.57 500 150 700 250 1.5 1.6 4.0 2 1.65 20 0\n",
       "label_02/0001.txt:4: field 1 (frame) is not a finite number: 'x'"},
      {"-1 2 Car 0 0 -1.57 500 150 700 250 1.5 1.6 4.0 2 1.65 20 0\n",
       "label_02/0001.txt:1: field 1 (frame) must be an integer >= 0, got '-1'"},
      {"0 -1 Car 0 0 -1.57 500 150 700 250 1.5 1.6 4.0 2 1.65 20 0\n",
       ":1: field 2 (track_id) must be an integer >= 0 (-1 is for DontCare), got '-1'"},
      {"0 2 Car 0.35 0 -1.57 500 150 700 250 1.5 1.6 4.0 2 1.65 20 0\n",
       ":1: field 4 (truncated) must be the truncation level 0, 1 or 2, got '0.35'"},
      {"0 2 Car 0 4 -1.57 500 150 700 250 1.5 1.6 4.0 2 1.65 20 0\n",
       ":1: field 5 (occluded) must be the occlusion level 0..3, got '4'"},
      {"0 2 Car 0 0 -1.57 500 150 700 250 1.5 1.6 4.0 2 nan 20 0\n",
       ":1: field 15 (y) is not a finite number"},
      {"0 2 Car 0 0 -1.57 700 150 500 250 1.5 1.6 4.0 2 1.65 20 0\n",
       ":1: box (left 700, top 150, right 500"},
      {"0 2 Car 0 0 -1.57 500 150 700 250 0 1.6 4.0 2 1.65 20 0\n",
       ":1: an object's height, width and length"},
      {good + carLine(0, 1, 3.0, 25.0),
       "label_02/0001.txt:2: track 1 appears twice in frame 0 (first on line 1)"},
  };
  for (const Case& c : cases)
  {
    const std::string error = errorOf(c.text);
    EXPECT_NE(error.find(c.message), std::string::npos) << "got: " << error << "\nfor:\n" << c.text;
  }
  // The same track in two frames, a DontCare and an object sharing a frame: fine.
  EXPECT_EQ(errorOf(good + carLine(1, 1, 2.0, 19.0) +
                    "0 -1 DontCare -1 -1 -10 1 2 3 4 -1000 -1000 -1000 -10 -1 -1 -1\n"),
            "");
  // A missing file is named.
  try
  {
    readTrackingLabels("/nonexistent/label_02/0001.txt");
    ADD_FAILURE() << "no error";
  }
  catch (const KittiLabelError& e)
  {
    EXPECT_NE(std::string(e.what()).find("/nonexistent/label_02/0001.txt"), std::string::npos) << e.what();
  }
}

TEST(TrackingLabels, WorldPositionAndRangeComputedByHand)
{
  // Track 4, frame 3: bottom centre (2, 1.65, 20) in the camera frame, 1.5 m high: centre (2, 0.9,
  // 20). velo = Rᵀ · (cam − T) = Rᵀ · (2, 1.0, 20.3) = (20.3, −2, −1.0): 20.3 m ahead. IMU =
  // velo − (−0.8, 0.3, −0.8) = (21.1, −2.3, −0.2); world = IMU + (3, 0, 0) = (24.1, −2.3).
  const KittiDrive drive = syntheticDrive(20);
  const TrackingGroundTruth truth =
      trackingLabelGroundTruth(parse(carLine(3, 4, 2.0, 20.0)), drive, KittiGroundTruthConfig{});
  ASSERT_EQ(truth.objects.size(), 1U);
  const GroundTruthObject& g = truth.objects[0];
  EXPECT_EQ(g.frame_index, 3);
  EXPECT_EQ(g.tracklet, 4);
  EXPECT_EQ(g.object.track_id, 4);
  EXPECT_EQ(g.object.frame, "0000000003");
  EXPECT_EQ(g.object.label, "car");
  EXPECT_NEAR(g.velo_center.x(), 20.3, 1e-5);
  EXPECT_NEAR(g.velo_center.y(), -2.0, 1e-5);
  EXPECT_NEAR(g.velo_center.z(), -1.0, 1e-5);
  EXPECT_NEAR(g.object.longitudinal_m, 20.3, 1e-5);
  ASSERT_TRUE(g.object.has_state);
  EXPECT_NEAR(g.object.x, 24.1, 1e-5);
  EXPECT_NEAR(g.object.y, -2.3, 1e-5);
  EXPECT_NEAR(g.object.time_s, 1000.3, 1e-6);
  // The labelled box, not the projection; a single frame has no speed: unknown, difficult.
  EXPECT_FLOAT_EQ(g.object.box.x_min, 500.F);
  EXPECT_FLOAT_EQ(g.object.box.y_max, 250.F);
  EXPECT_EQ(g.object.motion, Motion::kUnknown);
  EXPECT_TRUE(g.object.difficult);
}

TEST(TrackingLabels, BoxesClippedAndDifficultyFromTheLevels)
{
  // A car 20 m ahead, 2 m to the right: it projects fully into the image (truncation 0).
  const KittiDrive drive = syntheticDrive(20);
  std::string text;
  for (int f = 0; f < 15; ++f)
  {
    const double z = 20.0 - f;                         // parked: the ego closes in at 1 m per frame
    text += carLine(f, 0, 2.0, z, "-20 150 700 400");  // box outside: clipped
    text += carLine(f, 1, 2.0, z + 5.0, "500 150 700 250", f == 2 ? 2 : 1);     // level 2 in frame 2
    text += carLine(f, 2, 2.0, z + 8.0, "500 150 700 250", 0, f == 2 ? 2 : 1);  // occlusion 2 in frame 2
    text += carLine(f, 3, -14.0, z, "0 150 100 250");  // 14 m to the left: mostly outside the image
  }
  const TrackingGroundTruth truth = trackingLabelGroundTruth(parse(text), drive, KittiGroundTruthConfig{});
  const GroundTruthObject* clipped = find(truth, 0, 2);
  ASSERT_NE(clipped, nullptr);
  EXPECT_FLOAT_EQ(clipped->object.box.x_min, 0.F);
  EXPECT_FLOAT_EQ(clipped->object.box.y_max, 374.F);
  EXPECT_NEAR(clipped->truncation, 0.0, 1e-9);
  EXPECT_FALSE(clipped->object.difficult);
  EXPECT_FALSE(find(truth, 1, 1)->object.difficult);  // truncation level 1
  EXPECT_TRUE(find(truth, 1, 2)->object.difficult);   // truncation level 2
  EXPECT_FALSE(find(truth, 2, 1)->object.difficult);  // occlusion level 1
  EXPECT_TRUE(find(truth, 2, 2)->object.difficult);   // occlusion level 2
  const GroundTruthObject* cut = find(truth, 3, 5);   // the projected 3-D box is cut by the image edge
  ASSERT_NE(cut, nullptr);
  EXPECT_GT(cut->truncation, 0.5);
  EXPECT_TRUE(cut->object.difficult);
  KittiGroundTruthConfig lenient;
  lenient.max_truncation = 1.0;
  lenient.difficult_truncation_flag = 3;
  lenient.difficult_occlusion = 3;
  const TrackingGroundTruth relaxed = trackingLabelGroundTruth(parse(text), drive, lenient);
  EXPECT_FALSE(find(relaxed, 1, 2)->object.difficult);
  EXPECT_FALSE(find(relaxed, 2, 2)->object.difficult);
  EXPECT_FALSE(find(relaxed, 3, 5)->object.difficult);
}

TEST(TrackingLabels, ParkedCarWithJitterIsStaticMoverDynamic)
{
  // 30 frames (2.9 s). Track 0 parked 40 m ahead at first (world x 41.1 m), its labelled
  // position jittering by up to 5 cm in x and z from frame to frame as OXTS and annotation
  // noise do on KITTI. Track 1 drives ahead of the ego at 6 m/s (camera z 30 m, closing at
  // 0.4 m per frame), with the same jitter.
  const double jitter[] = {0.05, -0.03, 0.04, -0.05, 0.02, 0.05, -0.04, 0.0, -0.05, 0.03};
  const KittiDrive drive = syntheticDrive(30);
  std::string text;
  for (int f = 0; f < 30; ++f)
  {
    const double dx = jitter[f % 10];
    const double dz = jitter[(f + 3) % 10];
    text += carLine(f, 0, 2.0 + dx, 40.0 - f + dz);
    text += carLine(f, 1, -1.5 + dz, 30.0 - 0.4 * f + dx);
  }
  KittiGroundTruthConfig config;
  config.dynamic_speed_mps = 0.2;  // stricter than the default 0.5
  const TrackingGroundTruth truth = trackingLabelGroundTruth(parse(text), drive, config);
  ASSERT_EQ(truth.objects.size(), 60U);
  double parked_max = 0.0;
  std::vector<Eigen::Vector3d> parked_world;
  std::vector<double> times;
  for (int f = 0; f < 30; ++f)
  {
    const GroundTruthObject* parked = find(truth, 0, f);
    const GroundTruthObject* mover = find(truth, 1, f);
    ASSERT_NE(parked, nullptr);
    ASSERT_NE(mover, nullptr);
    EXPECT_EQ(parked->object.motion, Motion::kStatic) << "frame " << f << ": " << parked->speed_mps << " m/s";
    EXPECT_FALSE(parked->object.difficult);
    parked_max = std::max(parked_max, parked->speed_mps);
    EXPECT_EQ(mover->object.motion, Motion::kDynamic) << "frame " << f;
    EXPECT_NEAR(mover->speed_mps, 6.0, 0.1) << "frame " << f;
    EXPECT_NEAR(mover->object.vx, 6.0, 0.1) << "frame " << f;
    parked_world.emplace_back(parked->object.x, parked->object.y, 0.0);
    times.push_back(parked->object.time_s);
  }
  EXPECT_LT(parked_max, 0.1);
  // Differences over ±2 frames of the same positions would call it moving in some frames.
  double differenced_max = 0.0;
  for (std::size_t j = 0; j < times.size(); ++j)
  {
    differenced_max = std::max(differenced_max, trajectoryVelocity(parked_world, times, j, 2).norm());
  }
  EXPECT_GT(differenced_max, 0.45);  // 0.50 m/s
}

TEST(TrackingLabels, OxtsPositionsDriftingSidewaysDoNotMoveAParkedCar)
{
  // The ego drives straight along x, but its OXTS positions run 3 cm per frame to the left
  // (0.3 m/s, as drive 0009's run 1–2° off its heading). A parked car seen from the ego: its
  // world positions through the OXTS poses drift at 0.3 m/s; along the heading they stand.
  const KittiDrive drive = syntheticDrive(20, 0.03);
  std::string text;
  for (int f = 0; f < 20; ++f)
  {
    text += carLine(f, 0, 2.0, 25.0 - f);
  }
  KittiGroundTruthConfig config;
  config.dynamic_speed_mps = 0.2;
  const TrackingGroundTruth truth = trackingLabelGroundTruth(parse(text), drive, config);
  ASSERT_EQ(truth.objects.size(), 20U);
  for (const GroundTruthObject& g : truth.objects)
  {
    EXPECT_EQ(g.object.motion, Motion::kStatic) << "frame " << g.frame_index;
    EXPECT_LT(g.speed_mps, 1e-6) << "frame " << g.frame_index;
  }
  // Its position is the OXTS world's (the detections' frame): y = −2.3 + 0.03 · frame.
  EXPECT_NEAR(truth.objects[10].object.y, -2.3 + 0.3, 1e-5);
}

TEST(TrackingLabels, ShortTracksHaveNoMotion)
{
  // Frames 0.1 s apart: 10 frames span 0.9 s, less than the 1 s window: motion unknown,
  // difficult. 12 frames span 1.1 s: fitted. With a 0.5 s window the 10-frame track is fitted.
  const KittiDrive drive = syntheticDrive(20);
  std::string text;
  for (int f = 0; f < 12; ++f)
  {
    text += carLine(f, 7, 2.0, 19.0 - f);
    if (f < 10)
    {
      text += carLine(f, 8, -2.0, 19.0 - f);
    }
  }
  const TrackingGroundTruth truth = trackingLabelGroundTruth(parse(text), drive, KittiGroundTruthConfig{});
  for (int f = 0; f < 10; ++f)
  {
    EXPECT_EQ(find(truth, 7, f)->object.motion, Motion::kStatic);
    EXPECT_FALSE(find(truth, 7, f)->object.difficult);
    EXPECT_EQ(find(truth, 8, f)->object.motion, Motion::kUnknown);
    EXPECT_TRUE(find(truth, 8, f)->object.difficult);
  }
  KittiGroundTruthConfig half;
  half.speed_window_s = 0.5;
  const TrackingGroundTruth fitted = trackingLabelGroundTruth(parse(text), drive, half);
  EXPECT_EQ(find(fitted, 8, 0)->object.motion, Motion::kStatic);
  EXPECT_FALSE(find(fitted, 8, 0)->object.difficult);
}

TEST(TrackingLabels, FramesBeyondTheDriveAreCountedAndLeftOut)
{
  const KittiDrive drive = syntheticDrive(5);
  std::string text;
  for (int f = 0; f < 8; ++f)
  {
    text += carLine(f, 0, 2.0, 20.0 - f);
  }
  text += "6 -1 DontCare -1 -1 -10 1 2 3 4 -1000 -1000 -1000 -10 -1 -1 -1\n";
  const TrackingGroundTruth truth = trackingLabelGroundTruth(parse(text), drive, KittiGroundTruthConfig{});
  EXPECT_EQ(truth.objects.size(), 5U);
  EXPECT_EQ(truth.beyond_drive, 4U);
  EXPECT_EQ(truth.first_frame_beyond, 5);
  EXPECT_EQ(truth.last_frame_beyond, 7);
  EXPECT_EQ(truth.first_line_beyond, 6U);
}

TEST(TrackingLabels, ClassMapAndDontCareRegions)
{
  const KittiDrive drive = syntheticDrive(20);
  std::string text;
  for (int f = 0; f < 12; ++f)
  {
    text += carLine(f, 0, 2.0, 19.0 - f);
    text += std::to_string(f) + " 5 Van 0 0 -1.57 100 150 200 250 2.0 1.8 4.5 -3.0 1.65 15 -1.57\n";
  }
  text += "4 -1 DontCare -1 -1 -10 1100 150 1300 200 -1000 -1000 -1000 -10 -1 -1 -1\n";
  KittiGroundTruthConfig config;
  config.class_map = {{"van", "car"}};
  const TrackingGroundTruth truth = trackingLabelGroundTruth(parse(text), drive, config);
  ASSERT_EQ(truth.dont_care, 1U);
  std::size_t regions = 0;
  for (const GroundTruthObject& g : truth.objects)
  {
    if (g.object.dont_care)
    {
      ++regions;
      EXPECT_EQ(g.object.frame, "0000000004");
      EXPECT_EQ(g.tracklet, -1);
      EXPECT_FLOAT_EQ(g.object.box.x_max, 1241.F);  // clipped
    }
    else
    {
      EXPECT_EQ(g.object.label, "car");  // the van renamed
    }
  }
  EXPECT_EQ(regions, 1U);
  config.class_map = {{"van", ""}};
  const TrackingGroundTruth no_vans = trackingLabelGroundTruth(parse(text), drive, config);
  EXPECT_EQ(no_vans.objects.size(), 13U);  // 12 cars, 1 DontCare
}

TEST(TrackingLabels, TrackIdsAreTheTrackingMetricsIdentities)
{
  // Two parked cars side by side for 12 frames; the detector's ids swap after frame 5: each
  // ground-truth track is matched to another id from frame 6 on, two id switches; IDF1 from the
  // track ids: each identity co-matched 6 frames with each id.
  const KittiDrive drive = syntheticDrive(20);
  std::string text;
  for (int f = 0; f < 12; ++f)
  {
    text += carLine(f, 10, 2.0, 19.0 - f, "700 150 800 250");
    text += carLine(f, 11, -2.0, 19.0 - f, "300 150 400 250");
  }
  const TrackingGroundTruth truth = trackingLabelGroundTruth(parse(text), drive, KittiGroundTruthConfig{});
  const std::vector<EvalObject> ground_truth = evalObjects(truth.objects);
  std::vector<EvalObject> detections;
  for (const EvalObject& g : ground_truth)
  {
    EvalObject d = g;
    const int frame = std::stoi(g.frame);
    d.track_id = (g.track_id == 10) == (frame <= 5) ? 100 : 200;
    detections.push_back(d);
  }
  const TrackingMetrics m = evaluateTracking(ground_truth, detections, TrackingEvaluationConfig{});
  EXPECT_EQ(m.truth_tracks, 2U);
  EXPECT_EQ(m.matches, 24U);
  EXPECT_EQ(m.id_switches, 2U);
  EXPECT_EQ(m.idtp, 12U);
  EXPECT_EQ(m.idfn, 12U);
  EXPECT_EQ(m.idfp, 12U);
  // The matches carry the track id as the truth's identity.
  const EvaluationResult result = evaluate(ground_truth, detections, EvaluationConfig{});
  ASSERT_FALSE(result.matched_objects.empty());
  for (const MatchedObject& matched : result.matched_objects)
  {
    EXPECT_TRUE(matched.truth_id == 10 || matched.truth_id == 11);
  }
}

TEST(EvaluateTool, TrackingLabelsUsageAndMissingFile)
{
  // --labels with --tracking-labels: a usage error (exit 2) before anything is read; a tracking
  // label file that is not there: bad input (exit 1), named (the drive: test/data's drive 0001).
  const std::string tool = GVF_EVALUATE_TOOL;
  const std::string log = testing::TempDir() + "gvf_evaluate_tool.log";
  auto run = [&](const std::string& arguments)
  {
    const int status = std::system((tool + " " + arguments + " > " + log + " 2>&1").c_str());
    std::ifstream file(log);
    std::stringstream text;
    text << file.rdbuf();
    return std::make_pair(WEXITSTATUS(status), text.str());
  };
  const std::string drive =
      std::string(GVF_TEST_DATA_DIR) + "/kitti_raw_2011_09_26/2011_09_26_drive_0001_sync";
  const std::string common = "--drive " + drive + " --detections /nonexistent/run.bag --output " +
                             testing::TempDir() + "gvf_evaluate_tool_out";
  const auto both = run(common + " --labels /tmp --tracking-labels /nonexistent/0001.txt");
  EXPECT_EQ(both.first, 2) << both.second;
  EXPECT_NE(both.second.find("--labels and --tracking-labels"), std::string::npos) << both.second;
  const auto missing = run(common + " --tracking-labels /nonexistent/label_02/0001.txt");
  EXPECT_EQ(missing.first, 1) << missing.second;
  EXPECT_NE(missing.second.find("/nonexistent/label_02/0001.txt: cannot open"), std::string::npos)
      << missing.second;
  const auto window = run(common + " --tracking-labels /nonexistent/0001.txt --speed-window 0");
  EXPECT_EQ(window.first, 2) << window.second;
  EXPECT_NE(window.second.find("speed_window_s"), std::string::npos) << window.second;
}

TEST(FittedVelocity, LeastSquaresOverTheWindowCentredInsideOneSidedAtTheEnds)
{
  // x = t² at t = 0, 0.1, ..., 2.0 (21 samples). A window of 1 s at j = 10 (t = 1): samples 5..15,
  // symmetric, so the slope of the line is exactly dx/dt = 2 t = 2. At j = 0: samples 0..10
  // (t 0..1), the slope of t² over [0, 1] = 1. At j = 20: samples 10..20, slope 3.
  std::vector<Eigen::Vector3d> p;
  std::vector<double> t;
  for (int i = 0; i <= 20; ++i)
  {
    t.push_back(0.1 * i);
    p.emplace_back(t.back() * t.back(), 1.0, 0.0);
  }
  EXPECT_NEAR(fittedVelocity(p, t, 10, 1.0).x(), 2.0, 1e-9);
  EXPECT_NEAR(fittedVelocity(p, t, 10, 1.0).y(), 0.0, 1e-9);
  EXPECT_NEAR(fittedVelocity(p, t, 0, 1.0).x(), 1.0, 1e-9);
  EXPECT_NEAR(fittedVelocity(p, t, 20, 1.0).x(), 3.0, 1e-9);
  // Near an end: j = 2 takes samples 0..10 (t 0..1): one-sided as far as needed.
  EXPECT_NEAR(fittedVelocity(p, t, 2, 1.0).x(), 1.0, 1e-9);
  // A window longer than the trajectory: all of it (slope of t² over [0, 2] = 2).
  EXPECT_NEAR(fittedVelocity(p, t, 3, 5.0).x(), 2.0, 1e-9);
  // A gap: samples at 0, 0.1, 1.0, 1.1; at j = 0 the window grows to t = 1.0 (span 1 s).
  const std::vector<double> gap{0.0, 0.1, 1.0, 1.1};
  const std::vector<Eigen::Vector3d> line{{0.0, 0, 0}, {0.5, 0, 0}, {5.0, 0, 0}, {5.5, 0, 0}};
  EXPECT_NEAR(fittedVelocity(line, gap, 0, 1.0).x(), 5.0, 1e-9);
  EXPECT_TRUE(fittedVelocity({p[0]}, {0.0}, 0, 1.0).isZero());
  EXPECT_THROW(fittedVelocity(p, std::vector<double>(21, 1.0), 2, 1.0), std::invalid_argument);
  EXPECT_THROW(fittedVelocity(p, t, 21, 1.0), std::invalid_argument);
  EXPECT_THROW(fittedVelocity(p, t, 2, 0.0), std::invalid_argument);
}

}  // namespace grid_vision_fusion
