// Reader and writer of KITTI object label files (the 3-D object benchmark's label_2 format and the
// detection results submitted to it): one object per line,
//   type truncated occluded alpha left top right bottom height width length x y z rotation_y [score]
#pragma once

#include <istream>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

namespace grid_vision_fusion
{
/// One line of a KITTI object label file. Units and frames as in the KITTI devkit.
struct KittiObjectLabel
{
  /// "Car", "Van", "Truck", "Pedestrian", "Person_sitting", "Cyclist", "Tram", "Misc" or
  /// "DontCare" (any other word is accepted and kept as written).
  std::string type;
  float truncated = 0.F;  ///< fraction of the object outside the image, [0, 1] (-1 for DontCare)
  int occluded = 0;       ///< 0 visible, 1 partly, 2 largely occluded, 3 unknown (-1 for DontCare)
  float alpha = 0.F;      ///< observation angle [rad], [-pi, pi]
  float left = 0.F;       ///< 2-D box in the rectified image of camera 2 [px], x right, y down
  float top = 0.F;
  float right = 0.F;
  float bottom = 0.F;
  float height = 0.F;  ///< 3-D box dimensions [m]
  float width = 0.F;
  float length = 0.F;
  float x = 0.F;  ///< bottom centre of the 3-D box in the rectified camera frame [m]
  float y = 0.F;
  float z = 0.F;
  float rotation_y = 0.F;      ///< yaw around the camera y axis [rad], [-pi, pi]
  std::optional<float> score;  ///< 16th column (detection results only): confidence
};

/// A malformed label file; what() names the file (or source) and the 1-based line.
class KittiLabelError : public std::runtime_error
{
public:
  using std::runtime_error::runtime_error;
};

/// Parses the label lines of `input`. Blank lines are skipped. `source_name` (e.g. the path)
/// is used in error messages only.
/// @throws KittiLabelError "<source_name>:<line>: <what is wrong>" for a line with other than
///         15 or 16 fields, a field that is not a number (or not finite), an occlusion that is
///         not an integer, or a box with right < left or bottom < top.
std::vector<KittiObjectLabel> parseKittiLabels(std::istream& input, const std::string& source_name);

/// The whitespace-separated fields of one line of a KITTI text file.
std::vector<std::string> splitFields(const std::string& line);

/// `text` in lower case (ASCII): KITTI types and labels compare without regard to case.
std::string lowerCase(std::string text);

/// Reads the KITTI label file at `path`.
/// @throws KittiLabelError when the file cannot be opened ("<path>: cannot open ...") or a
///         line is malformed (see parseKittiLabels()).
std::vector<KittiObjectLabel> readKittiLabels(const std::string& path);

/// One label as a line of a KITTI label file, without the newline: the 15 fields, then the
/// score as a 16th when it is set. Numbers are written in the shortest form that reads back to
/// the same float, so parseKittiLabels() of the line gives `label` back exactly.
/// @throws std::invalid_argument when the type is empty or holds whitespace, or a number is
///         not finite (the line would not parse).
std::string formatKittiLabel(const KittiObjectLabel& label);

/// Writes `labels` as the KITTI label file `path`, one formatKittiLabel() line each (an empty
/// file for none). The file is written as `path`.tmp and renamed once complete, so that a
/// reader never sees half a file and a failure leaves an existing file as it was.
/// @throws KittiLabelError naming the file when it cannot be written; std::invalid_argument
///         as formatKittiLabel().
void writeKittiLabels(const std::string& path, const std::vector<KittiObjectLabel>& labels);

}  // namespace grid_vision_fusion
