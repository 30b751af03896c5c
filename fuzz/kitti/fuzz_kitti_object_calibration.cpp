// Fuzz harness: KITTI object-benchmark calibration files (calib/NNNNNN.txt).
#include <sstream>
#include <stdexcept>

#include "fuzz_input.h"
#include "grid_vision_fusion/kitti/kitti_calibration.h"

GVF_FUZZ_TARGET(kitti_object_calibration)
{
  using grid_vision_fusion::KittiCalibrationFile;
  std::istringstream input(gvf_fuzz::text(data, size));
  try
  {
    grid_vision_fusion::KittiObjectCalibration::fromFile(KittiCalibrationFile::parse(input, "fuzz"));
  }
  catch (const std::runtime_error&)
  {
  }
  return 0;
}
