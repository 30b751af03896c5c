#include "grid_vision_fusion/kitti/kitti_calibration.h"

#include <cmath>
#include <fstream>
#include <sstream>
#include <stdexcept>

namespace grid_vision_fusion
{
namespace
{
constexpr double kRotationTolerance = 1e-4;
/// Largest width or height of a rectified image (S_rect_0i) [px].
constexpr int kMaxImageSize = 1 << 20;

std::string trim(const std::string& text)
{
  const auto begin = text.find_first_not_of(" \t\r");
  if (begin == std::string::npos)
  {
    return {};
  }
  const auto end = text.find_last_not_of(" \t\r");
  return text.substr(begin, end - begin + 1);
}

/// Parses every whitespace-separated token of `text` as a double; false if one is not a number.
bool parseNumbers(const std::string& text, std::vector<double>& numbers)
{
  std::istringstream stream(text);
  std::string token;
  numbers.clear();
  while (stream >> token)
  {
    std::size_t used = 0;
    double value = 0.0;
    try
    {
      value = std::stod(token, &used);
    }
    catch (const std::exception&)
    {
      return false;
    }
    if (used != token.size() || !std::isfinite(value))
    {
      return false;
    }
    numbers.push_back(value);
  }
  return true;
}

std::string joinPath(const std::string& directory, const std::string& name)
{
  if (directory.empty() || directory.back() == '/')
  {
    return directory + name;
  }
  return directory + "/" + name;
}

Eigen::Isometry3d rigidFromKeys(const KittiCalibrationFile& file, const std::string& rotation_key,
                                const std::string& translation_key)
{
  return rigidTransform(file.matrix<3, 3>(rotation_key), file.matrix<3, 1>(translation_key),
                        file.source() + ": " + rotation_key);
}

Eigen::Isometry3d rigidFromRow34(const KittiCalibrationFile& file, const std::string& key)
{
  const Eigen::Matrix<double, 3, 4> m = file.matrix<3, 4>(key);
  return rigidTransform(m.leftCols<3>(), m.col(3), file.source() + ": " + key);
}
}  // namespace

KittiCalibrationFile KittiCalibrationFile::read(const std::string& path)
{
  std::ifstream input(path);
  if (!input)
  {
    throw std::runtime_error("KITTI calibration file " + path + " cannot be opened");
  }
  return parse(input, path);
}

KittiCalibrationFile KittiCalibrationFile::parse(std::istream& input, const std::string& source)
{
  KittiCalibrationFile file;
  file.source_ = source;
  std::string line;
  int line_number = 0;
  while (std::getline(input, line))
  {
    ++line_number;
    if (trim(line).empty())
    {
      continue;
    }
    const auto colon = line.find(':');
    if (colon == std::string::npos)
    {
      throw std::runtime_error("KITTI calibration file " + source + ", line " + std::to_string(line_number) +
                               ": no 'key:' in \"" + trim(line) + "\"");
    }
    const std::string key = trim(line.substr(0, colon));
    const std::string rest = line.substr(colon + 1);
    std::vector<double> numbers;
    if (parseNumbers(rest, numbers) && !numbers.empty())
    {
      file.numeric_[key] = std::move(numbers);
    }
    else
    {
      file.text_[key] = trim(rest);
    }
  }
  return file;
}

bool KittiCalibrationFile::has(const std::string& key) const
{
  return numeric_.count(key) > 0;
}

std::vector<double> KittiCalibrationFile::values(const std::string& key, std::size_t count) const
{
  const auto found = numeric_.find(key);
  if (found == numeric_.end())
  {
    if (text_.count(key) > 0)
    {
      throw std::runtime_error("KITTI calibration file " + source_ + ": key " + key +
                               " does not hold numbers: \"" + text_.at(key) + "\"");
    }
    throw std::runtime_error("KITTI calibration file " + source_ + ": key " + key + " is missing");
  }
  if (found->second.size() != count)
  {
    throw std::runtime_error("KITTI calibration file " + source_ + ": key " + key + " has " +
                             std::to_string(found->second.size()) + " values, expected " +
                             std::to_string(count));
  }
  return found->second;
}

Eigen::Isometry3d rigidTransform(const Eigen::Matrix3d& rotation, const Eigen::Vector3d& translation,
                                 const std::string& what)
{
  const double orthonormality =
      (rotation * rotation.transpose() - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff();
  if (!(orthonormality < kRotationTolerance) ||
      !(std::abs(rotation.determinant() - 1.0) < kRotationTolerance))
  {
    throw std::runtime_error(what +
                             " is not a rotation matrix (|R·Rᵀ − I| = " + std::to_string(orthonormality) +
                             ", det = " + std::to_string(rotation.determinant()) + ")");
  }
  Eigen::Isometry3d transform = Eigen::Isometry3d::Identity();
  transform.linear() = rotation;
  transform.translation() = translation;
  return transform;
}

KittiRawCalibration KittiRawCalibration::readDirectory(const std::string& directory)
{
  // One after the other, so that the first missing file is the one named.
  const KittiCalibrationFile cam_to_cam =
      KittiCalibrationFile::read(joinPath(directory, "calib_cam_to_cam.txt"));
  const KittiCalibrationFile velo_to_cam =
      KittiCalibrationFile::read(joinPath(directory, "calib_velo_to_cam.txt"));
  const KittiCalibrationFile imu_to_velo =
      KittiCalibrationFile::read(joinPath(directory, "calib_imu_to_velo.txt"));
  return fromFiles(cam_to_cam, velo_to_cam, imu_to_velo);
}

KittiRawCalibration KittiRawCalibration::fromFiles(const KittiCalibrationFile& cam_to_cam,
                                                   const KittiCalibrationFile& velo_to_cam,
                                                   const KittiCalibrationFile& imu_to_velo)
{
  KittiRawCalibration calibration;
  for (int i = 0; i < 4; ++i)
  {
    const std::string suffix = "_0" + std::to_string(i);
    calibration.p_rect[static_cast<std::size_t>(i)] = cam_to_cam.matrix<3, 4>("P_rect" + suffix);
    calibration.r_rect[static_cast<std::size_t>(i)] =
        rigidTransform(cam_to_cam.matrix<3, 3>("R_rect" + suffix), Eigen::Vector3d::Zero(),
                       cam_to_cam.source() + ": R_rect" + suffix)
            .linear();
    const std::vector<double> size = cam_to_cam.values("S_rect" + suffix, 2);
    if (!(size[0] >= 1.0 && size[1] >= 1.0 && size[0] <= kMaxImageSize && size[1] <= kMaxImageSize))
    {
      throw std::runtime_error("KITTI calibration file " + cam_to_cam.source() + ": key S_rect" + suffix +
                               " is not a positive image size of at most " + std::to_string(kMaxImageSize) +
                               " px");
    }
    calibration.image_size[static_cast<std::size_t>(i)] = {static_cast<std::uint32_t>(std::lround(size[0])),
                                                           static_cast<std::uint32_t>(std::lround(size[1]))};
  }
  calibration.cam0_from_velo = rigidFromKeys(velo_to_cam, "R", "T");
  calibration.velo_from_imu = rigidFromKeys(imu_to_velo, "R", "T");
  return calibration;
}

Eigen::Isometry3d KittiRawCalibration::rectifiedFromVelo() const
{
  Eigen::Isometry3d rectify = Eigen::Isometry3d::Identity();
  rectify.linear() = r_rect[0];
  return rectify * cam0_from_velo;
}

ProjectionMatrix KittiRawCalibration::veloToImage(int camera) const
{
  if (camera < 0 || camera > 3)
  {
    throw std::out_of_range("KITTI camera index " + std::to_string(camera) + " is not in 0..3");
  }
  return p_rect[static_cast<std::size_t>(camera)] * rectifiedFromVelo().matrix();
}

KittiObjectCalibration KittiObjectCalibration::read(const std::string& path)
{
  return fromFile(KittiCalibrationFile::read(path));
}

KittiObjectCalibration KittiObjectCalibration::fromFile(const KittiCalibrationFile& file)
{
  KittiObjectCalibration calibration;
  for (int i = 0; i < 4; ++i)
  {
    calibration.p[static_cast<std::size_t>(i)] = file.matrix<3, 4>("P" + std::to_string(i));
  }
  calibration.r0_rect =
      rigidTransform(file.matrix<3, 3>("R0_rect"), Eigen::Vector3d::Zero(), file.source() + ": R0_rect")
          .linear();
  calibration.cam0_from_velo = rigidFromRow34(file, "Tr_velo_to_cam");
  calibration.velo_from_imu = rigidFromRow34(file, "Tr_imu_to_velo");
  return calibration;
}

Eigen::Isometry3d KittiObjectCalibration::rectifiedFromVelo() const
{
  Eigen::Isometry3d rectify = Eigen::Isometry3d::Identity();
  rectify.linear() = r0_rect;
  return rectify * cam0_from_velo;
}

}  // namespace grid_vision_fusion
