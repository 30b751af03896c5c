// Unit tests of the KITTI calibration readers, on the real 2011_09_26 raw calibration and the
// object-benchmark calibration files (test/data, KITTI CC BY-NC-SA 3.0, see the READMEs there).
#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>

#include "grid_vision_fusion/core/kitti_calibration.h"

namespace grid_vision_fusion
{
namespace
{
const std::string kRawDir = std::string(GVF_TEST_DATA_DIR) + "/kitti_raw_2011_09_26";
const std::string kObjectCalib = std::string(GVF_TEST_DATA_DIR) + "/kitti_object_samples/calib/000002.txt";

/// Expects `call` to throw std::runtime_error whose message contains every one of `parts`.
template <typename Call>
void expectErrorNaming(Call call, std::initializer_list<std::string> parts)
{
  try
  {
    call();
    FAIL() << "no exception thrown";
  }
  catch (const std::runtime_error& e)
  {
    for (const auto& part : parts)
    {
      EXPECT_NE(std::string(e.what()).find(part), std::string::npos)
          << "'" << part << "' not in: " << e.what();
    }
  }
}

/// A temporary directory with copies of the three raw calibration files, one of them rewritten.
class TempCalibrationDir
{
public:
  TempCalibrationDir()
  {
    char pattern[] = "/tmp/gvf_kitti_calib_XXXXXX";
    const char* made = mkdtemp(pattern);
    if (made == nullptr)
    {
      throw std::runtime_error("mkdtemp failed");
    }
    path_ = made;
    for (const char* name : {"calib_cam_to_cam.txt", "calib_velo_to_cam.txt", "calib_imu_to_velo.txt"})
    {
      std::ifstream in(kRawDir + "/" + name);
      std::ofstream out(path_ + "/" + name);
      out << in.rdbuf();
    }
  }
  ~TempCalibrationDir()
  {
    for (const char* name : {"calib_cam_to_cam.txt", "calib_velo_to_cam.txt", "calib_imu_to_velo.txt"})
    {
      std::remove((path_ + "/" + name).c_str());
    }
    std::remove(path_.c_str());
  }
  /// Rewrites file `name` without the lines starting with `key` + ':'.
  void dropKey(const std::string& name, const std::string& key) const
  {
    std::ifstream in(path_ + "/" + name);
    std::stringstream kept;
    std::string line;
    while (std::getline(in, line))
    {
      if (line.rfind(key + ":", 0) != 0)
      {
        kept << line << "\n";
      }
    }
    in.close();
    std::ofstream(path_ + "/" + name) << kept.str();
  }
  const std::string& path() const { return path_; }

private:
  std::string path_;
};

TEST(KittiRawCalibration, ReadsTheRealDayCalibration)
{
  const KittiRawCalibration calib = KittiRawCalibration::readDirectory(kRawDir);
  EXPECT_DOUBLE_EQ(calib.p_rect[2](0, 0), 721.5377);
  EXPECT_DOUBLE_EQ(calib.p_rect[2](0, 2), 609.5593);
  EXPECT_DOUBLE_EQ(calib.p_rect[2](0, 3), 44.85728);
  EXPECT_DOUBLE_EQ(calib.p_rect[2](1, 3), 0.2163791);
  EXPECT_DOUBLE_EQ(calib.p_rect[2](2, 3), 0.002745884);
  EXPECT_DOUBLE_EQ(calib.p_rect[3](0, 3), -339.5242);
  EXPECT_DOUBLE_EQ(calib.r_rect[0](0, 1), 0.00983776);
  EXPECT_DOUBLE_EQ(calib.r_rect[0](2, 2), 0.9999631);
  EXPECT_EQ(calib.image_size[2][0], 1242U);
  EXPECT_EQ(calib.image_size[2][1], 375U);
  EXPECT_DOUBLE_EQ(calib.cam0_from_velo.linear()(0, 1), -0.9999714);
  EXPECT_DOUBLE_EQ(calib.cam0_from_velo.translation().x(), -4.069766e-03);
  EXPECT_DOUBLE_EQ(calib.cam0_from_velo.translation().z(), -2.717806e-01);
  EXPECT_DOUBLE_EQ(calib.velo_from_imu.translation().x(), -0.8086759);
  EXPECT_DOUBLE_EQ(calib.velo_from_imu.translation().z(), -0.7997231);
}

TEST(KittiRawCalibration, VeloToImageIsTheKittiChain)
{
  const KittiRawCalibration calib = KittiRawCalibration::readDirectory(kRawDir);
  // The chain against the explicit product P_rect_02 · R_rect_00 · Tr_velo_to_cam.
  Eigen::Matrix4d rect = Eigen::Matrix4d::Identity();
  rect.topLeftCorner<3, 3>() = calib.r_rect[0];
  const ProjectionMatrix expected = calib.p_rect[2] * rect * calib.cam0_from_velo.matrix();
  EXPECT_TRUE(calib.veloToImage(2).isApprox(expected, 1e-12));
  // KITTI check values of DESIGN.md: (10, 0, −1.73) → (615.3, 303.5).
  const Eigen::Vector3d pixel = calib.veloToImage(2) * Eigen::Vector4d(10.0, 0.0, -1.73, 1.0);
  EXPECT_NEAR(pixel.x() / pixel.z(), 615.3, 0.5);
  EXPECT_NEAR(pixel.y() / pixel.z(), 303.5, 0.5);
  EXPECT_THROW(calib.veloToImage(4), std::out_of_range);
}

TEST(KittiObjectCalibration, ReadsAnObjectBenchmarkFile)
{
  const KittiObjectCalibration calib = KittiObjectCalibration::read(kObjectCalib);
  EXPECT_DOUBLE_EQ(calib.p[2](0, 0), 721.5377);
  EXPECT_DOUBLE_EQ(calib.p[2](0, 3), 44.85728);
  EXPECT_DOUBLE_EQ(calib.p[3](2, 3), 0.002729905);
  EXPECT_DOUBLE_EQ(calib.r0_rect(0, 1), 0.00983776);
  EXPECT_DOUBLE_EQ(calib.cam0_from_velo.linear()(0, 0), 7.533745e-03);
  EXPECT_DOUBLE_EQ(calib.cam0_from_velo.translation().y(), -7.631618e-02);
  EXPECT_DOUBLE_EQ(calib.velo_from_imu.translation().y(), 0.3195559);
  // Frame 000002 was recorded on 2011_09_26: its chain equals the raw day's.
  const KittiRawCalibration raw = KittiRawCalibration::readDirectory(kRawDir);
  EXPECT_TRUE(calib.rectifiedFromVelo().matrix().isApprox(raw.rectifiedFromVelo().matrix(), 1e-9));
}

TEST(KittiCalibrationFile, KeepsTextValuesApartFromNumbers)
{
  std::istringstream text("calib_time: 09-Jan-2012 13:57:47\nS_rect_00: 1.242000e+03 3.750000e+02\n\n");
  const KittiCalibrationFile file = KittiCalibrationFile::parse(text, "inline.txt");
  EXPECT_TRUE(file.has("S_rect_00"));
  EXPECT_FALSE(file.has("calib_time"));
  EXPECT_EQ(file.values("S_rect_00", 2), (std::vector<double>{1242.0, 375.0}));
  expectErrorNaming([&] { file.values("calib_time", 1); },
                    {"inline.txt", "calib_time", "does not hold numbers"});
}

TEST(KittiCalibrationFile, ErrorsNameTheFileAndTheKey)
{
  std::istringstream text("P2: 1 2 3\n");
  const KittiCalibrationFile file = KittiCalibrationFile::parse(text, "calib/000042.txt");
  expectErrorNaming([&] { file.values("R0_rect", 9); }, {"calib/000042.txt", "R0_rect", "missing"});
  expectErrorNaming([&] { file.matrix<3, 4>("P2"); }, {"calib/000042.txt", "P2", "3 values", "expected 12"});

  std::istringstream no_colon("P2 1 2 3\n");
  expectErrorNaming([&] { KittiCalibrationFile::parse(no_colon, "broken.txt"); }, {"broken.txt", "line 1"});
  expectErrorNaming([] { KittiCalibrationFile::read("/nonexistent/calib.txt"); },
                    {"/nonexistent/calib.txt", "cannot be opened"});
  expectErrorNaming([] { KittiObjectCalibration::read("/nonexistent/000000.txt"); },
                    {"/nonexistent/000000.txt"});
}

TEST(KittiRawCalibration, MissingFileOrKeyIsNamed)
{
  expectErrorNaming([] { KittiRawCalibration::readDirectory("/nonexistent_dir"); },
                    {"/nonexistent_dir/calib_cam_to_cam.txt"});
  {
    TempCalibrationDir dir;
    dir.dropKey("calib_cam_to_cam.txt", "P_rect_02");
    expectErrorNaming([&] { KittiRawCalibration::readDirectory(dir.path()); },
                      {dir.path() + "/calib_cam_to_cam.txt", "P_rect_02", "missing"});
  }
  {
    TempCalibrationDir dir;
    dir.dropKey("calib_velo_to_cam.txt", "T");
    expectErrorNaming([&] { KittiRawCalibration::readDirectory(dir.path()); },
                      {dir.path() + "/calib_velo_to_cam.txt", "key T", "missing"});
  }
  {
    TempCalibrationDir dir;
    dir.dropKey("calib_imu_to_velo.txt", "R");
    std::ofstream(dir.path() + "/calib_imu_to_velo.txt", std::ios::app) << "R: 2 0 0 0 1 0 0 0 1\n";
    expectErrorNaming([&] { KittiRawCalibration::readDirectory(dir.path()); },
                      {dir.path() + "/calib_imu_to_velo.txt", "R", "not a rotation"});
  }
}

}  // namespace
}  // namespace grid_vision_fusion
