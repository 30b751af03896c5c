// Tests of the KITTI raw readers on the real metadata of drive 2011_09_26_0001 (test/data, KITTI
// CC BY-NC-SA 3.0) and on broken files written by the tests.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <stdexcept>

#include "grid_vision_fusion/kitti/kitti_raw.h"

namespace grid_vision_fusion
{
namespace
{
const std::string kDrive =
    std::string(GVF_TEST_DATA_DIR) + "/kitti_raw_2011_09_26/2011_09_26_drive_0001_sync";

std::string writeTemp(const std::string& name, const std::string& content)
{
  const std::string path = testing::TempDir() + name;
  std::ofstream(path) << content;
  return path;
}

template <typename F>
std::string errorOf(F&& f)
{
  try
  {
    f();
  }
  catch (const std::runtime_error& e)
  {
    return e.what();
  }
  return "";
}
}  // namespace

TEST(KittiOxts, ReadsTheRealDrive)
{
  const std::vector<OxtsRecord> records = readOxtsFolder(kDrive + "/oxts");
  ASSERT_EQ(records.size(), 108U);
  EXPECT_DOUBLE_EQ(records[0].lat, 49.015003823272);
  EXPECT_DOUBLE_EQ(records[0].lon, 8.4342971002335);
  EXPECT_DOUBLE_EQ(records[0].yaw, -2.6087069803847);
  EXPECT_DOUBLE_EQ(records[0].vf, 13.172716663769);
  EXPECT_EQ(records[0].numsats, 11);
  EXPECT_EQ(records[0].orimode, 6);
}

TEST(KittiOxts, PosesRelativeToTheFirstFrame)
{
  // Reference values from an independent numpy transcription of the devkit's convertOxtsToPose
  // (Mercator scale cos(49.0150°), R = Rz·Ry·Rx, T0⁻¹·Ti). Frame 1 is 0.1 s after frame 0 at
  // vf = 13.17 m/s: ~1.44 m ahead, as the numbers say.
  const std::vector<Eigen::Isometry3d> poses = oxtsPosesRelativeToFirst(readOxtsFolder(kDrive + "/oxts"));
  ASSERT_EQ(poses.size(), 108U);
  EXPECT_TRUE(poses[0].isApprox(Eigen::Isometry3d::Identity(), 1e-9));
  EXPECT_NEAR(poses[1].translation().x(), 1.4424816836, 1e-6);
  EXPECT_NEAR(poses[1].translation().y(), 0.0124398614, 1e-6);
  EXPECT_NEAR(poses[1].translation().z(), 0.0145361725, 1e-6);
  const auto yaw = [](const Eigen::Isometry3d& p) { return std::atan2(p.linear()(1, 0), p.linear()(0, 0)); };
  EXPECT_NEAR(yaw(poses[1]), -0.0022599650, 1e-8);
  EXPECT_NEAR(poses[107].translation().x(), 106.3587853541, 1e-5);
  EXPECT_NEAR(poses[107].translation().y(), -10.0295830606, 1e-5);
  EXPECT_NEAR(poses[107].translation().z(), 1.3382739269, 1e-5);
  EXPECT_NEAR(yaw(poses[107]), -0.1445716873, 1e-8);
}

TEST(KittiOxts, MercatorPoseOfTheEquatorOrigin)
{
  OxtsRecord r;  // lat = lon = 0: the Mercator origin
  r.alt = 5.0;
  r.yaw = M_PI / 2;
  const Eigen::Isometry3d pose = oxtsToMercatorPose(r, mercatorScale(0.0));
  EXPECT_NEAR(pose.translation().norm() - 5.0, 0.0, 1e-9);
  EXPECT_TRUE(
      pose.linear().isApprox(Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitZ()).toRotationMatrix()));
  // One degree of longitude at the equator: 6378137·π/180 = 111319.49 m east.
  r.lon = 1.0;
  EXPECT_NEAR(oxtsToMercatorPose(r, 1.0).translation().x(), 111319.490793, 1e-5);
}

TEST(KittiOxts, MalformedRecordsNameTheFile)
{
  EXPECT_NE(errorOf([] { parseOxtsLine("1 2 3", "rec.txt"); })
                .find("rec.txt: an OXTS record needs 30 numbers, read 3"),
            std::string::npos);
  EXPECT_NE(errorOf([] { parseOxtsLine("1 2 x", "rec.txt"); }).find("non-number"), std::string::npos);
  EXPECT_NE(
      errorOf([] { readOxtsFolder("/nonexistent/oxts"); }).find("/nonexistent/oxts/data/0000000000.txt"),
      std::string::npos);
}

TEST(KittiTimestamps, ParsesNanoseconds)
{
  const std::vector<KittiStamp> stamps = readTimestamps(kDrive + "/image_02/timestamps.txt");
  ASSERT_EQ(stamps.size(), 108U);
  // 2011-09-26 13:02:25 UTC = 1317042145 s since the epoch.
  EXPECT_EQ(stamps[0].sec, 1317042145);
  EXPECT_EQ(stamps[0].nsec, 961661696U);
  EXPECT_NEAR(stamps[1].toSec() - stamps[0].toSec(), 0.103123456, 1e-6);
  const KittiStamp short_fraction = parseKittiStamp("2011-09-26 13:02:25.5", "x");
  EXPECT_EQ(short_fraction.nsec, 500000000U);
  EXPECT_NE(errorOf([] { parseKittiStamp("2011-09-26 13:02", "cam.txt:3"); }).find("cam.txt:3"),
            std::string::npos);
  const std::string bad = writeTemp("bad_stamps.txt", "2011-09-26 13:02:25.1\nnot a stamp\n");
  EXPECT_NE(errorOf([&] { readTimestamps(bad); }).find("bad_stamps.txt:2"), std::string::npos);
}

TEST(KittiTracklets, ReadsTheRealLabels)
{
  const std::vector<Tracklet> tracklets = readTracklets(kDrive + "/tracklet_labels.xml");
  ASSERT_EQ(tracklets.size(), 15U);
  int cars = 0, cyclists = 0, trams = 0;
  for (const auto& t : tracklets)
  {
    cars += t.object_type == "Car";
    cyclists += t.object_type == "Cyclist";
    trams += t.object_type == "Tram";
  }
  EXPECT_EQ(cars, 12);
  EXPECT_EQ(cyclists, 2);
  EXPECT_EQ(trams, 1);
  const Tracklet& first = tracklets[0];
  EXPECT_EQ(first.object_type, "Car");
  EXPECT_DOUBLE_EQ(first.h, 2.1672349);
  EXPECT_DOUBLE_EQ(first.l, 4.3293562);
  EXPECT_EQ(first.first_frame, 0);
  ASSERT_EQ(first.poses.size(), 14U);
  EXPECT_DOUBLE_EQ(first.poses[1].tx, 23.865835133576148);
  EXPECT_DOUBLE_EQ(first.poses[0].rz, -3.1842001424562025);
  EXPECT_EQ(first.poses[0].state, 2);
  EXPECT_TRUE(first.inFrame(13));
  EXPECT_FALSE(first.inFrame(14));
}

TEST(KittiTracklets, BrokenFilesNameTheFault)
{
  EXPECT_NE(errorOf([] { readTracklets("/nonexistent/tracklet_labels.xml"); })
                .find("/nonexistent/tracklet_labels.xml"),
            std::string::npos);
  const std::string wrong_count = writeTemp(
      "wrong_count.xml",
      "<boost_serialization><tracklets><count>2</count><item><objectType>Car</objectType><h>1</h><w>1</"
      "w><l>1</l>"
      "<first_frame>0</first_frame><poses><count>0</count></poses></item></tracklets></boost_serialization>");
  EXPECT_NE(errorOf([&] { readTracklets(wrong_count); }).find("<count> says 2 tracklets, found 1"),
            std::string::npos);
  const std::string no_type = writeTemp("no_type.xml",
                                        "<boost_serialization><tracklets><count>1</count><item><h>1</h></"
                                        "item></tracklets></boost_serialization>");
  EXPECT_NE(errorOf([&] { readTracklets(no_type); }).find("tracklet 0: missing or malformed <objectType>"),
            std::string::npos);
}

TEST(AlongHeadingPoses, TheSidewaysDriftGoesTheLengthAndTheTurnsStay)
{
  // Heading along x, positions running 0.03 m sideways per 1 m forward: laid along x.
  std::vector<Eigen::Isometry3d> drifting(5, Eigen::Isometry3d::Identity());
  for (int i = 0; i < 5; ++i)
  {
    drifting[i].translation() = Eigen::Vector3d(i, 0.03 * i, 0.0);
  }
  const std::vector<Eigen::Isometry3d> laid = alongHeadingPoses(drifting);
  ASSERT_EQ(laid.size(), 5U);
  EXPECT_TRUE(laid[4].translation().isApprox(Eigen::Vector3d(4.0, 0.0, 0.0), 1e-12));
  EXPECT_TRUE(laid[4].linear().isApprox(drifting[4].linear(), 1e-12));
  // A turn without slip (on a circle of radius 20 m, heading along the tangent): kept.
  std::vector<Eigen::Isometry3d> circle;
  for (int i = 0; i < 10; ++i)
  {
    const double a = 0.05 * i;
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
    pose.linear() = Eigen::AngleAxisd(a, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    pose.translation() = Eigen::Vector3d(20.0 * std::sin(a), 20.0 * (1.0 - std::cos(a)), 0.0);
    circle.push_back(pose);
  }
  const std::vector<Eigen::Isometry3d> kept = alongHeadingPoses(circle);
  for (std::size_t i = 0; i < circle.size(); ++i)
  {
    EXPECT_TRUE(kept[i].translation().isApprox(circle[i].translation(), 1e-9)) << i;
  }
  // Standing still with jittering positions: the jitter along the heading only, no creeping.
  std::vector<Eigen::Isometry3d> standing(3, Eigen::Isometry3d::Identity());
  standing[1].translation() = Eigen::Vector3d(0.02, 0.01, 0.0);
  standing[2].translation() = Eigen::Vector3d(-0.01, -0.02, 0.0);
  EXPECT_TRUE(alongHeadingPoses(standing)[2].translation().isApprox(Eigen::Vector3d(-0.01, 0.0, 0.0), 1e-12));
  EXPECT_TRUE(alongHeadingPoses({}).empty());
}

}  // namespace grid_vision_fusion
