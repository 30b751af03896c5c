// Readers of the KITTI calibration files: the raw-data day files (calib_cam_to_cam.txt,
// calib_velo_to_cam.txt, calib_imu_to_velo.txt) and the object-benchmark files (calib/NNNNNN.txt).
// Conventions of Geiger et al., "Vision meets Robotics: The KITTI Dataset", IJRR 2013: a point X
// of the velodyne frame lands on pixel (u, v) of camera i (rectified image) through
//   w·(u, v, 1)ᵀ = P_rect_0i · R_rect_00 · Tr_velo_to_cam · (X, 1)ᵀ.
#pragma once

#include <Eigen/Geometry>

#include <array>
#include <cstdint>
#include <iosfwd>
#include <map>
#include <string>
#include <vector>

namespace grid_vision_fusion
{
/// 3×4 projection matrix of a rectified camera [px].
using ProjectionMatrix = Eigen::Matrix<double, 3, 4>;

/// The "key: v1 v2 ..." lines of one KITTI calibration text file. Lines whose values are not all
/// numbers (e.g. "calib_time: 09-Jan-2012 13:57:47") are kept as text only. Every accessor throws
/// with a message naming the file and the key.
class KittiCalibrationFile
{
public:
  /// Reads and parses the file at `path`. @throws std::runtime_error when it cannot be opened or
  /// a line has no ':' (naming the file and the line number).
  static KittiCalibrationFile read(const std::string& path);
  /// Parses `input`; `source` names it in error messages. @throws std::runtime_error as read().
  static KittiCalibrationFile parse(std::istream& input, const std::string& source);

  /// The name the file was read from.
  const std::string& source() const { return source_; }
  /// Whether `key` is present with numeric values.
  bool has(const std::string& key) const;
  /// The numeric values of `key`. @throws std::runtime_error when the key is missing, its
  /// values are not numbers, or there are not exactly `count` of them.
  std::vector<double> values(const std::string& key, std::size_t count) const;
  /// The values of `key` as a row-major Rows×Cols matrix. @throws std::runtime_error as values().
  template <int Rows, int Cols>
  Eigen::Matrix<double, Rows, Cols> matrix(const std::string& key) const
  {
    const std::vector<double> v = values(key, static_cast<std::size_t>(Rows * Cols));
    Eigen::Matrix<double, Rows, Cols> m;
    for (int r = 0; r < Rows; ++r)
    {
      for (int c = 0; c < Cols; ++c)
      {
        m(r, c) = v[static_cast<std::size_t>(r * Cols + c)];
      }
    }
    return m;
  }

private:
  std::string source_;
  std::map<std::string, std::vector<double>> numeric_;
  std::map<std::string, std::string> text_;
};

/// A rigid transform from a 3×3 rotation and a translation [m]. @throws std::runtime_error
/// naming `what` when the rotation is not orthonormal with determinant +1 (tolerance 1e-4).
Eigen::Isometry3d rigidTransform(const Eigen::Matrix3d& rotation, const Eigen::Vector3d& translation,
                                 const std::string& what);

/// Calibration of one KITTI raw recording day (e.g. 2011_09_26), read from its three files.
struct KittiRawCalibration
{
  /// P_rect_0i of camera i = 0..3 (0, 1 grey, 2, 3 colour), rectified images [px].
  std::array<ProjectionMatrix, 4> p_rect;
  /// R_rect_0i: rotation of camera i into its rectified frame.
  std::array<Eigen::Matrix3d, 4> r_rect;
  /// S_rect_0i: width and height of the rectified image of camera i [px].
  std::array<std::array<std::uint32_t, 2>, 4> image_size;
  /// Tr_velo_to_cam: unrectified camera 0 ← velodyne (R, T of calib_velo_to_cam.txt).
  Eigen::Isometry3d cam0_from_velo = Eigen::Isometry3d::Identity();
  /// Tr_imu_to_velo: velodyne ← IMU (R, T of calib_imu_to_velo.txt).
  Eigen::Isometry3d velo_from_imu = Eigen::Isometry3d::Identity();

  /// Reads calib_cam_to_cam.txt, calib_velo_to_cam.txt and calib_imu_to_velo.txt of
  /// `directory`. @throws std::runtime_error naming the file and key at fault.
  static KittiRawCalibration readDirectory(const std::string& directory);
  /// The calibration of the three parsed files. @throws std::runtime_error as readDirectory().
  static KittiRawCalibration fromFiles(const KittiCalibrationFile& cam_to_cam,
                                       const KittiCalibrationFile& velo_to_cam,
                                       const KittiCalibrationFile& imu_to_velo);

  /// R_rect_00 · Tr_velo_to_cam: the rectified camera-0 frame ← velodyne, the frame in which
  /// every P_rect_0i applies.
  Eigen::Isometry3d rectifiedFromVelo() const;
  /// P_rect_0i · R_rect_00 · Tr_velo_to_cam: velodyne point → homogeneous pixel of camera i.
  /// @throws std::out_of_range for camera > 3.
  ProjectionMatrix veloToImage(int camera) const;
};

/// Calibration of one KITTI object-benchmark frame (calib/NNNNNN.txt).
struct KittiObjectCalibration
{
  /// P0..P3: projection matrices of the rectified cameras [px].
  std::array<ProjectionMatrix, 4> p;
  /// R0_rect: rectifying rotation of camera 0.
  Eigen::Matrix3d r0_rect = Eigen::Matrix3d::Identity();
  /// Tr_velo_to_cam: unrectified camera 0 ← velodyne.
  Eigen::Isometry3d cam0_from_velo = Eigen::Isometry3d::Identity();
  /// Tr_imu_to_velo: velodyne ← IMU.
  Eigen::Isometry3d velo_from_imu = Eigen::Isometry3d::Identity();

  /// Reads one object-benchmark calibration file. @throws std::runtime_error naming the file
  /// and the missing or malformed key.
  static KittiObjectCalibration read(const std::string& path);
  /// The calibration of a parsed object-benchmark file. @throws std::runtime_error as read().
  static KittiObjectCalibration fromFile(const KittiCalibrationFile& file);

  /// R0_rect · Tr_velo_to_cam: rectified camera-0 frame (the frame of the label_2 boxes) ← velodyne.
  Eigen::Isometry3d rectifiedFromVelo() const;
};

}  // namespace grid_vision_fusion
