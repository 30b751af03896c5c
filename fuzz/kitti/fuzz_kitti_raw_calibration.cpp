// Fuzz harness: the three KITTI raw calibration files (calib_cam_to_cam.txt,
// calib_velo_to_cam.txt, calib_imu_to_velo.txt), given as three parts of the input.
#include <sstream>
#include <stdexcept>

#include "fuzz_input.h"
#include "grid_vision_fusion/kitti/kitti_calibration.h"

GVF_FUZZ_TARGET(kitti_raw_calibration)
{
  using grid_vision_fusion::KittiCalibrationFile;
  const std::vector<std::string> files = gvf_fuzz::parts(data, size, 3);
  std::istringstream cam_to_cam(files[0]);
  std::istringstream velo_to_cam(files[1]);
  std::istringstream imu_to_velo(files[2]);
  try
  {
    grid_vision_fusion::KittiRawCalibration::fromFiles(
        KittiCalibrationFile::parse(cam_to_cam, "cam_to_cam"),
        KittiCalibrationFile::parse(velo_to_cam, "velo_to_cam"),
        KittiCalibrationFile::parse(imu_to_velo, "imu_to_velo"));
  }
  catch (const std::runtime_error&)
  {
  }
  return 0;
}
