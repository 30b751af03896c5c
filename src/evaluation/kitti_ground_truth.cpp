#include "grid_vision_fusion/evaluation/kitti_ground_truth.h"

#include <algorithm>
#include <array>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>
#include <stdexcept>

#include "grid_vision_fusion/projection/box_projection.h"

namespace grid_vision_fusion
{
namespace
{
std::string parentOf(const std::string& dir)
{
  std::filesystem::path path(dir);
  if (!path.has_filename())
  {
    path = path.parent_path();  // "a/b/" → "a/b"
  }
  const std::filesystem::path parent = path.parent_path();
  return parent.empty() ? std::string(".") : parent.string();
}

const char* const kTrackingFields[] = {"frame",  "track_id", "type",  "truncated", "occluded",   "alpha",
                                       "left",   "top",      "right", "bottom",    "height",     "width",
                                       "length", "x",        "y",     "z",         "rotation_y", "score"};

[[noreturn]] void failAt(const std::string& source, std::size_t line, const std::string& what)
{
  throw KittiLabelError(source + ":" + std::to_string(line) + ": " + what);
}

std::string fieldName(std::size_t field)
{
  return "field " + std::to_string(field + 1) + " (" + kTrackingFields[field] + ")";
}

/// Token `field` of a tracking label line as a finite number.
double finiteField(const std::vector<std::string>& tokens, std::size_t field, const std::string& source,
                   std::size_t line)
{
  const std::string& token = tokens[field];
  errno = 0;
  char* end = nullptr;
  const double value = std::strtod(token.c_str(), &end);
  if (end == token.c_str() || *end != '\0' || errno == ERANGE || !std::isfinite(value))
  {
    failAt(source, line, fieldName(field) + " is not a finite number: '" + token + "'");
  }
  return value;
}

/// Token `field` as an integer in [lowest, highest]; `what` names the range in the message.
int integerField(const std::vector<std::string>& tokens, std::size_t field, int lowest, int highest,
                 const std::string& what, const std::string& source, std::size_t line)
{
  const double value = finiteField(tokens, field, source, line);
  if (value != std::floor(value) || value < lowest || value > highest)
  {
    failAt(source, line, fieldName(field) + " must be " + what + ", got '" + tokens[field] + "'");
  }
  return static_cast<int>(value);
}

/// One line of a tracking label file (17 or 18 tokens), checked as parseTrackingLabels() says.
TrackingLabel parseTrackingLine(const std::vector<std::string>& tokens, const std::string& source,
                                std::size_t line)
{
  if (tokens.size() != 17 && tokens.size() != 18)
  {
    failAt(source, line,
           "expected 17 fields (frame track_id type truncated occluded alpha left top right bottom h w l x "
           "y z ry) or 18 with a score, got " +
               std::to_string(tokens.size()));
  }
  TrackingLabel label;
  label.line = line;
  KittiObjectLabel& o = label.object;
  o.type = tokens[2];
  const bool dont_care = label.dontCare();
  constexpr int kMax = std::numeric_limits<int>::max();
  label.frame = integerField(tokens, 0, 0, kMax, "an integer >= 0", source, line);
  if (dont_care)  // track_id −1, truncated and occluded −1 in KITTI's files: not checked further
  {
    label.track_id = -1;
    o.truncated = static_cast<float>(finiteField(tokens, 3, source, line));
    o.occluded = integerField(tokens, 4, std::numeric_limits<int>::min(), kMax, "an integer", source, line);
    finiteField(tokens, 1, source, line);
  }
  else
  {
    label.track_id = integerField(tokens, 1, 0, kMax, "an integer >= 0 (-1 is for DontCare)", source, line);
    o.truncated =
        static_cast<float>(integerField(tokens, 3, 0, 2, "the truncation level 0, 1 or 2", source, line));
    o.occluded = integerField(tokens, 4, 0, 3, "the occlusion level 0..3", source, line);
  }
  float* const numbers[] = {&o.alpha, &o.left,   &o.top, &o.right, &o.bottom, &o.height,
                            &o.width, &o.length, &o.x,   &o.y,     &o.z,      &o.rotation_y};
  for (std::size_t i = 0; i < 12; ++i)
  {
    *numbers[i] = static_cast<float>(finiteField(tokens, 5 + i, source, line));
  }
  if (tokens.size() == 18)
  {
    o.score = static_cast<float>(finiteField(tokens, 17, source, line));
  }
  if (o.right < o.left || o.bottom < o.top)
  {
    std::ostringstream what;
    what << "box (left " << o.left << ", top " << o.top << ", right " << o.right << ", bottom " << o.bottom
         << ") has right < left or bottom < top";
    failAt(source, line, what.str());
  }
  if (!dont_care && !(o.height > 0.F && o.width > 0.F && o.length > 0.F))
  {
    failAt(source, line, "an object's height, width and length (fields 11-13) must be > 0");
  }
  return label;
}

Motion parseMotion(const std::string& token)
{
  const std::string word = lowerCase(token);
  if (word == "static")
  {
    return Motion::kStatic;
  }
  if (word == "dynamic")
  {
    return Motion::kDynamic;
  }
  return Motion::kUnknown;
}
}  // namespace

std::string kittiFrameName(int index)
{
  if (index < 0)
  {
    throw std::invalid_argument("frame index must be >= 0, got " + std::to_string(index));
  }
  char name[32];
  std::snprintf(name, sizeof(name), "%010d", index);
  return name;
}

void KittiGroundTruthConfig::validate() const
{
  if (camera < 0 || camera > 3)
  {
    throw std::invalid_argument("camera must be in 0..3, got " + std::to_string(camera));
  }
  if (!(dynamic_speed_mps >= 0.0) || !std::isfinite(dynamic_speed_mps))
  {
    throw std::invalid_argument("dynamic_speed_mps must be a finite value >= 0, got " +
                                std::to_string(dynamic_speed_mps));
  }
  if (speed_half_window < 1)
  {
    throw std::invalid_argument("speed_half_window must be >= 1, got " + std::to_string(speed_half_window));
  }
  if (!(speed_window_s > 0.0) || !std::isfinite(speed_window_s))
  {
    throw std::invalid_argument("speed_window_s must be a finite value > 0, got " +
                                std::to_string(speed_window_s));
  }
  if (!(max_truncation >= 0.0 && max_truncation <= 1.0))
  {
    throw std::invalid_argument("max_truncation must be in [0, 1], got " + std::to_string(max_truncation));
  }
  if (difficult_occlusion < 0 || difficult_occlusion > 3)
  {
    throw std::invalid_argument("difficult_occlusion must be in 0..3, got " +
                                std::to_string(difficult_occlusion));
  }
  if (difficult_truncation_flag < 1)
  {
    throw std::invalid_argument("difficult_truncation_flag must be >= 1, got " +
                                std::to_string(difficult_truncation_flag));
  }
  if (!(near_plane_m > 0.0) || !std::isfinite(near_plane_m))
  {
    throw std::invalid_argument("near_plane_m must be a finite value > 0, got " +
                                std::to_string(near_plane_m));
  }
}

std::string KittiGroundTruthConfig::labelOf(const std::string& object_type) const
{
  const std::string type = lowerCase(object_type);
  const auto mapped = class_map.find(type);
  if (mapped != class_map.end())
  {
    return mapped->second;
  }
  return keep_unmapped ? type : std::string();
}

KittiDrive KittiDrive::read(const std::string& drive_dir, const std::string& calibration_dir,
                            bool with_tracklets)
{
  KittiDrive drive;
  const std::string stamps_path = drive_dir + "/image_02/timestamps.txt";
  drive.stamps = readTimestamps(stamps_path);
  const std::vector<OxtsRecord> oxts = readOxtsFolder(drive_dir + "/oxts");
  if (oxts.size() != drive.stamps.size())
  {
    throw std::runtime_error(stamps_path + " has " + std::to_string(drive.stamps.size()) +
                             " time stamps but " + drive_dir + "/oxts/data holds " +
                             std::to_string(oxts.size()) + " records: not a synced drive");
  }
  for (std::size_t i = 1; i < drive.stamps.size(); ++i)
  {
    if (!(drive.stamps[i].toSec() > drive.stamps[i - 1].toSec()))
    {
      throw std::runtime_error(stamps_path + ":" + std::to_string(i + 1) +
                               ": time stamp not after the previous one");
    }
  }
  drive.world_from_imu = oxtsPosesRelativeToFirst(oxts);
  drive.odom_from_imu = alongHeadingPoses(drive.world_from_imu);
  drive.calibration =
      KittiRawCalibration::readDirectory(calibration_dir.empty() ? parentOf(drive_dir) : calibration_dir);
  if (with_tracklets)
  {
    drive.tracklets = readTracklets(drive_dir + "/tracklet_labels.xml");
  }
  return drive;
}

Eigen::Isometry3d KittiDrive::worldFromVelo(int frame) const
{
  if (frame < 0 || frame >= static_cast<int>(world_from_imu.size()))
  {
    throw std::out_of_range("frame " + std::to_string(frame) + " outside the drive's " +
                            std::to_string(world_from_imu.size()) + " frames");
  }
  return world_from_imu[static_cast<std::size_t>(frame)] * calibration.velo_from_imu.inverse();
}

Eigen::Isometry3d KittiDrive::worldFromOdom(int frame) const
{
  if (frame < 0 || frame >= static_cast<int>(odom_from_imu.size()))
  {
    throw std::out_of_range("frame " + std::to_string(frame) + " outside the drive's " +
                            std::to_string(odom_from_imu.size()) + " frames");
  }
  const auto f = static_cast<std::size_t>(frame);
  return world_from_imu[f] * odom_from_imu[f].inverse();
}

std::vector<double> KittiDrive::frameTimes() const
{
  std::vector<double> times;
  times.reserve(stamps.size());
  for (const KittiStamp& s : stamps)
  {
    times.push_back(s.toSec());
  }
  return times;
}

bool projectVeloBox(const KittiRawCalibration& calibration, int camera,
                    const Eigen::Vector3d& bottom_center_velo, double yaw, double length, double width,
                    double height, double near_plane_m, BoundingBox& box, double& truncation)
{
  const Eigen::Isometry3d rectified_from_velo = calibration.rectifiedFromVelo();
  std::array<Eigen::Vector3d, 8> corners = orientedBoxCorners(bottom_center_velo, yaw, length, width, height);
  for (Eigen::Vector3d& c : corners)
  {
    c = rectified_from_velo * c;
  }
  const auto cam = static_cast<std::size_t>(camera);
  const ImageBox projected = projectBoxCorners(
      corners, calibration.p_rect.at(cam), static_cast<int>(calibration.image_size.at(cam)[0]),
      static_cast<int>(calibration.image_size.at(cam)[1]), near_plane_m);
  box = projected.box;
  truncation = projected.truncation;
  return projected.in_view;
}

Eigen::Vector3d trajectoryVelocity(const std::vector<Eigen::Vector3d>& positions,
                                   const std::vector<double>& times, std::size_t j, int half_window)
{
  if (positions.size() != times.size() || j >= positions.size() || half_window < 1)
  {
    throw std::invalid_argument("trajectoryVelocity: sizes differ, sample out of range or half window < 1");
  }
  const std::size_t h = static_cast<std::size_t>(half_window);
  const std::size_t lo = j >= h ? j - h : 0;
  const std::size_t hi = std::min(positions.size() - 1, j + h);
  if (lo == hi)
  {
    return Eigen::Vector3d::Zero();
  }
  const double dt = times[hi] - times[lo];
  if (!(dt > 0.0))
  {
    throw std::invalid_argument("trajectoryVelocity: times do not increase");
  }
  return (positions[hi] - positions[lo]) / dt;
}

Eigen::Vector3d fittedVelocity(const std::vector<Eigen::Vector3d>& positions,
                               const std::vector<double>& times, std::size_t j, double window_s)
{
  if (positions.size() != times.size() || j >= positions.size() || !(window_s > 0.0))
  {
    throw std::invalid_argument("fittedVelocity: sizes differ, sample out of range or window not > 0");
  }
  const std::size_t n = positions.size();
  std::size_t lo = j;
  std::size_t hi = j;
  while (times[hi] - times[lo] < window_s && (lo > 0 || hi + 1 < n))
  {
    const bool lower = lo > 0 && (hi + 1 == n || times[j] - times[lo - 1] <= times[hi + 1] - times[j]);
    if (lower)
    {
      --lo;
    }
    else
    {
      ++hi;
    }
    if (!(times[lo + 1] > times[lo]) || !(times[hi] > times[hi - 1]))
    {
      throw std::invalid_argument("fittedVelocity: times do not increase");
    }
  }
  if (lo == hi)
  {
    return Eigen::Vector3d::Zero();
  }
  const auto count = static_cast<double>(hi - lo + 1);
  double mean_t = 0.0;
  Eigen::Vector3d mean_p = Eigen::Vector3d::Zero();
  for (std::size_t i = lo; i <= hi; ++i)
  {
    mean_t += times[i] / count;
    mean_p += positions[i] / count;
  }
  double stt = 0.0;
  Eigen::Vector3d stp = Eigen::Vector3d::Zero();
  for (std::size_t i = lo; i <= hi; ++i)
  {
    stt += (times[i] - mean_t) * (times[i] - mean_t);
    stp += (times[i] - mean_t) * (positions[i] - mean_p);
  }
  return stp / stt;
}

std::vector<GroundTruthObject> trackletGroundTruth(const KittiDrive& drive,
                                                   const KittiGroundTruthConfig& config)
{
  config.validate();
  const std::vector<double> frame_times = drive.frameTimes();
  std::vector<GroundTruthObject> out;
  for (std::size_t k = 0; k < drive.tracklets.size(); ++k)
  {
    const Tracklet& tracklet = drive.tracklets[k];
    const std::string label = config.labelOf(tracklet.object_type);
    if (label.empty() || tracklet.poses.empty())
    {
      continue;
    }
    const int last = tracklet.first_frame + static_cast<int>(tracklet.poses.size()) - 1;
    if (tracklet.first_frame < 0 || last >= drive.frameCount())
    {
      throw std::runtime_error("tracklet " + std::to_string(k) + " (" + tracklet.object_type +
                               ") spans frames " + std::to_string(tracklet.first_frame) + ".." +
                               std::to_string(last) + " but the drive has " +
                               std::to_string(drive.frameCount()) + " frames");
    }
    // World trajectory of the box centre.
    std::vector<Eigen::Vector3d> world;
    std::vector<double> times;
    for (std::size_t j = 0; j < tracklet.poses.size(); ++j)
    {
      const TrackletPose& p = tracklet.poses[j];
      const int frame = tracklet.first_frame + static_cast<int>(j);
      world.push_back(drive.worldFromVelo(frame) * Eigen::Vector3d(p.tx, p.ty, p.tz + tracklet.h / 2.0));
      times.push_back(frame_times[static_cast<std::size_t>(frame)]);
    }
    for (std::size_t j = 0; j < tracklet.poses.size(); ++j)
    {
      const TrackletPose& p = tracklet.poses[j];
      GroundTruthObject gt;
      gt.frame_index = tracklet.first_frame + static_cast<int>(j);
      gt.tracklet = static_cast<int>(k);
      if (!projectVeloBox(drive.calibration, config.camera, Eigen::Vector3d(p.tx, p.ty, p.tz), p.rz,
                          tracklet.l, tracklet.w, tracklet.h, config.near_plane_m, gt.object.box,
                          gt.truncation))
      {
        continue;
      }
      gt.velo_center = Eigen::Vector3d(p.tx, p.ty, p.tz + tracklet.h / 2.0);
      EvalObject& o = gt.object;
      o.frame = kittiFrameName(gt.frame_index);
      o.label = label;
      o.score = 1.F;
      o.longitudinal_m = gt.velo_center.x();
      o.difficult = gt.truncation > config.max_truncation || p.occlusion >= config.difficult_occlusion ||
                    (p.truncation >= config.difficult_truncation_flag && p.truncation != 99);
      o.has_state = true;
      o.track_id = static_cast<std::int64_t>(k);
      o.time_s = times[j];
      o.x = world[j].x();
      o.y = world[j].y();
      if (tracklet.poses.size() < 2)
      {
        o.motion = Motion::kUnknown;
        o.difficult = true;  // no speed, no motion class: ignored
      }
      else
      {
        const Eigen::Vector3d v = trajectoryVelocity(world, times, j, config.speed_half_window);
        o.vx = v.x();
        o.vy = v.y();
        gt.speed_mps = std::hypot(v.x(), v.y());
        o.motion = gt.speed_mps > config.dynamic_speed_mps ? Motion::kDynamic : Motion::kStatic;
      }
      out.push_back(std::move(gt));
    }
  }
  std::stable_sort(out.begin(), out.end(),
                   [](const GroundTruthObject& a, const GroundTruthObject& b)
                   { return a.frame_index < b.frame_index; });
  return out;
}

std::vector<MotionLabel> parseMotionLabels(std::istream& input, const std::string& source_name)
{
  // Strip the motion token from every line, keeping the line numbering, and let the KITTI
  // reader check the rest.
  std::ostringstream kitti_part;
  std::vector<Motion> motions;
  std::string text;
  std::size_t line = 0;
  while (std::getline(input, text))
  {
    ++line;
    std::vector<std::string> tokens = splitFields(text);
    if (tokens.empty())
    {
      kitti_part << '\n';
      continue;
    }
    if (tokens.size() != 16 && tokens.size() != 17)
    {
      throw KittiLabelError(
          source_name + ":" + std::to_string(line) +
          ": expected 15 KITTI fields, an optional score and a motion (static or dynamic), got " +
          std::to_string(tokens.size()) + " fields");
    }
    const Motion motion = parseMotion(tokens.back());
    if (motion == Motion::kUnknown)
    {
      throw KittiLabelError(source_name + ":" + std::to_string(line) +
                            ": last field must be static or dynamic, got '" + tokens.back() + "'");
    }
    motions.push_back(motion);
    tokens.pop_back();
    for (std::size_t i = 0; i < tokens.size(); ++i)
    {
      kitti_part << (i ? " " : "") << tokens[i];
    }
    kitti_part << '\n';
  }
  std::istringstream stripped(kitti_part.str());
  const std::vector<KittiObjectLabel> labels = parseKittiLabels(stripped, source_name);
  std::vector<MotionLabel> out(labels.size());
  for (std::size_t i = 0; i < labels.size(); ++i)
  {
    out[i].label = labels[i];
    out[i].motion = motions[i];
  }
  return out;
}

std::vector<MotionLabel> readMotionLabels(const std::string& path)
{
  std::ifstream file(path);
  if (!file)
  {
    throw KittiLabelError(path + ": cannot open the label file");
  }
  return parseMotionLabels(file, path);
}

std::vector<GroundTruthObject> labelFolderGroundTruth(const std::string& label_dir,
                                                      const KittiRawCalibration& calibration,
                                                      const KittiGroundTruthConfig& config)
{
  config.validate();
  namespace fs = std::filesystem;
  std::error_code error;
  if (!fs::is_directory(label_dir, error))
  {
    throw std::runtime_error(label_dir + ": not a folder of label files");
  }
  std::vector<std::pair<int, std::string>> files;
  for (const fs::directory_entry& entry : fs::directory_iterator(label_dir))
  {
    const fs::path& path = entry.path();
    const std::string stem = path.stem().string();
    if (path.extension() != ".txt" || stem.empty() || stem.size() > 10 ||
        !std::all_of(stem.begin(), stem.end(), [](unsigned char c) { return std::isdigit(c); }))
    {
      continue;
    }
    const long long index = std::stoll(stem);
    if (index > std::numeric_limits<int>::max())
    {
      throw std::runtime_error(path.string() + ": frame index beyond " +
                               std::to_string(std::numeric_limits<int>::max()));
    }
    files.emplace_back(static_cast<int>(index), path.string());
  }
  if (files.empty())
  {
    throw std::runtime_error(label_dir + ": no label files named <frame index>.txt");
  }
  std::sort(files.begin(), files.end());
  for (std::size_t i = 1; i < files.size(); ++i)
  {
    if (files[i].first == files[i - 1].first)
    {
      throw std::runtime_error(files[i].second + " and " + files[i - 1].second + " name the same frame");
    }
  }
  const auto camera = static_cast<std::size_t>(config.camera);
  const double max_u = static_cast<double>(calibration.image_size.at(camera)[0]) - 1.0;
  const double max_v = static_cast<double>(calibration.image_size.at(camera)[1]) - 1.0;
  const Eigen::Isometry3d velo_from_rect = calibration.rectifiedFromVelo().inverse();
  std::vector<GroundTruthObject> out;
  for (const auto& [index, path] : files)
  {
    for (const MotionLabel& m : readMotionLabels(path))
    {
      const KittiObjectLabel& l = m.label;
      const std::string label = lowerCase(l.type) == "dontcare" ? std::string() : config.labelOf(l.type);
      if (label.empty())
      {
        continue;
      }
      GroundTruthObject gt;
      gt.frame_index = index;
      gt.truncation = l.truncated;
      gt.velo_center = velo_from_rect * Eigen::Vector3d(l.x, l.y - l.height / 2.0, l.z);
      EvalObject& o = gt.object;
      o.frame = kittiFrameName(index);
      o.label = label;
      o.motion = m.motion;
      o.box = BoundingBox{static_cast<float>(std::clamp<double>(l.left, 0.0, max_u)),
                          static_cast<float>(std::clamp<double>(l.top, 0.0, max_v)),
                          static_cast<float>(std::clamp<double>(l.right, 0.0, max_u)),
                          static_cast<float>(std::clamp<double>(l.bottom, 0.0, max_v))};
      o.difficult = l.truncated > config.max_truncation || l.occluded >= config.difficult_occlusion;
      o.longitudinal_m = gt.velo_center.x();
      out.push_back(std::move(gt));
    }
  }
  return out;
}

std::vector<TrackingLabel> parseTrackingLabels(std::istream& input, const std::string& source_name)
{
  std::vector<TrackingLabel> labels;
  std::map<std::pair<int, int>, std::size_t> line_of;  // (frame, track_id) -> line, objects only
  std::string text;
  std::size_t line = 0;
  while (std::getline(input, text))
  {
    ++line;
    const std::vector<std::string> tokens = splitFields(text);
    if (tokens.empty())
    {
      continue;
    }
    TrackingLabel label = parseTrackingLine(tokens, source_name, line);
    if (!label.dontCare())
    {
      const auto [seen, fresh] = line_of.emplace(std::make_pair(label.frame, label.track_id), line);
      if (!fresh)
      {
        failAt(source_name, line,
               "track " + std::to_string(label.track_id) + " appears twice in frame " +
                   std::to_string(label.frame) + " (first on line " + std::to_string(seen->second) + ")");
      }
    }
    labels.push_back(std::move(label));
  }
  if (input.bad())
  {
    throw KittiLabelError(source_name + ": read error after line " + std::to_string(line));
  }
  return labels;
}

std::vector<TrackingLabel> readTrackingLabels(const std::string& path)
{
  std::ifstream file(path);
  if (!file)
  {
    throw KittiLabelError(path + ": cannot open the tracking label file");
  }
  return parseTrackingLabels(file, path);
}

namespace
{
/// The labelled box clipped to the image of `camera`.
BoundingBox clippedBox(const KittiObjectLabel& l, const KittiRawCalibration& calibration, int camera)
{
  const auto c = static_cast<std::size_t>(camera);
  const double max_u = static_cast<double>(calibration.image_size.at(c)[0]) - 1.0;
  const double max_v = static_cast<double>(calibration.image_size.at(c)[1]) - 1.0;
  return BoundingBox{static_cast<float>(std::clamp<double>(l.left, 0.0, max_u)),
                     static_cast<float>(std::clamp<double>(l.top, 0.0, max_v)),
                     static_cast<float>(std::clamp<double>(l.right, 0.0, max_u)),
                     static_cast<float>(std::clamp<double>(l.bottom, 0.0, max_v))};
}

/// The ground truth of one object line (no motion yet): box, label, identity, difficulty by the
/// truncation and occlusion, world position, longitudinal distance.
GroundTruthObject trackingObject(const TrackingLabel& t, const std::string& label, const KittiDrive& drive,
                                 const KittiGroundTruthConfig& config)
{
  const KittiObjectLabel& l = t.object;
  const Eigen::Isometry3d velo_from_rect = drive.calibration.rectifiedFromVelo().inverse();
  const Eigen::Vector3d bottom = velo_from_rect * Eigen::Vector3d(l.x, l.y, l.z);
  // The object's x axis (its length, heading) in the rectified camera frame: R_y(ry) · e_x.
  const Eigen::Vector3d heading =
      velo_from_rect.linear() * Eigen::Vector3d(std::cos(l.rotation_y), 0.0, -std::sin(l.rotation_y));
  GroundTruthObject gt;
  gt.frame_index = t.frame;
  gt.tracklet = t.track_id;
  BoundingBox projected;
  if (!projectVeloBox(drive.calibration, config.camera, bottom, std::atan2(heading.y(), heading.x()),
                      l.length, l.width, l.height, config.near_plane_m, projected, gt.truncation))
  {
    gt.truncation = 1.0;  // its 3-D box does not project into the image: as truncated as can be
  }
  gt.velo_center = velo_from_rect * Eigen::Vector3d(l.x, l.y - l.height / 2.0, l.z);
  const Eigen::Vector3d world = drive.worldFromVelo(t.frame) * gt.velo_center;
  EvalObject& o = gt.object;
  o.frame = kittiFrameName(t.frame);
  o.label = label;
  o.score = 1.F;
  o.box = clippedBox(l, drive.calibration, config.camera);
  o.longitudinal_m = gt.velo_center.x();
  o.difficult = gt.truncation > config.max_truncation || l.truncated >= config.difficult_truncation_flag ||
                l.occluded >= config.difficult_occlusion;
  o.has_state = true;
  o.track_id = t.track_id;
  o.time_s = drive.stamps[static_cast<std::size_t>(t.frame)].toSec();
  o.x = world.x();
  o.y = world.y();
  return gt;
}

/// Velocity and motion of every object of one track (indices into `objects`, in frame order),
/// from its positions in its frames.
void fitTrackMotion(std::vector<GroundTruthObject>& objects, const std::vector<std::size_t>& track,
                    const std::vector<Eigen::Vector3d>& positions, const KittiGroundTruthConfig& config)
{
  std::vector<double> times;
  for (std::size_t i : track)
  {
    times.push_back(objects[i].object.time_s);
  }
  const bool too_short = times.back() - times.front() < config.speed_window_s;
  for (std::size_t j = 0; j < track.size(); ++j)
  {
    GroundTruthObject& gt = objects[track[j]];
    EvalObject& o = gt.object;
    if (too_short)
    {
      o.motion = Motion::kUnknown;
      o.difficult = true;  // no speed, no motion class: ignored
      continue;
    }
    const Eigen::Vector3d v = fittedVelocity(positions, times, j, config.speed_window_s);
    o.vx = v.x();
    o.vy = v.y();
    gt.speed_mps = std::hypot(v.x(), v.y());
    o.motion = gt.speed_mps > config.dynamic_speed_mps ? Motion::kDynamic : Motion::kStatic;
  }
}

/// A DontCare region of frame `t.frame`: its box clipped to the image.
GroundTruthObject dontCareRegion(const TrackingLabel& t, const KittiDrive& drive,
                                 const KittiGroundTruthConfig& config)
{
  GroundTruthObject gt;
  gt.frame_index = t.frame;
  EvalObject& o = gt.object;
  o.frame = kittiFrameName(t.frame);
  o.label = "dontcare";
  o.box = clippedBox(t.object, drive.calibration, config.camera);
  o.difficult = true;
  o.dont_care = true;
  o.time_s = drive.stamps[static_cast<std::size_t>(t.frame)].toSec();
  return gt;
}
}  // namespace

TrackingGroundTruth trackingLabelGroundTruth(const std::vector<TrackingLabel>& labels,
                                             const KittiDrive& drive, const KittiGroundTruthConfig& config)
{
  config.validate();
  TrackingGroundTruth out;
  std::map<int, std::vector<std::size_t>> tracks;  // track_id -> indices into out.objects
  for (const TrackingLabel& t : labels)
  {
    if (t.frame < 0 || t.frame >= drive.frameCount())
    {
      if (out.beyond_drive++ == 0)
      {
        out.first_frame_beyond = t.frame;
        out.first_line_beyond = t.line;
      }
      out.first_frame_beyond = std::min(out.first_frame_beyond, t.frame);
      out.last_frame_beyond = std::max(out.last_frame_beyond, t.frame);
      continue;
    }
    if (t.dontCare())
    {
      out.objects.push_back(dontCareRegion(t, drive, config));
      ++out.dont_care;
      continue;
    }
    const std::string label = config.labelOf(t.object.type);
    if (!label.empty())
    {
      tracks[t.track_id].push_back(out.objects.size());
      out.objects.push_back(trackingObject(t, label, drive, config));
    }
  }
  // The velocities from the positions on the ego's path laid along its heading.
  const std::vector<Eigen::Isometry3d>& along_heading = drive.odom_from_imu;
  const Eigen::Isometry3d imu_from_velo = drive.calibration.velo_from_imu.inverse();
  for (auto& [id, track] : tracks)
  {
    (void)id;
    std::sort(track.begin(), track.end(),
              [&](std::size_t a, std::size_t b)
              { return out.objects[a].frame_index < out.objects[b].frame_index; });
    std::vector<Eigen::Vector3d> positions;
    for (std::size_t i : track)
    {
      const auto frame = static_cast<std::size_t>(out.objects[i].frame_index);
      positions.push_back(along_heading.at(frame) * imu_from_velo * out.objects[i].velo_center);
    }
    fitTrackMotion(out.objects, track, positions, config);
  }
  std::stable_sort(out.objects.begin(), out.objects.end(),
                   [](const GroundTruthObject& a, const GroundTruthObject& b)
                   { return a.frame_index < b.frame_index; });
  return out;
}

int nearestFrame(const std::vector<double>& frame_times, double t, double tolerance_s)
{
  if (frame_times.empty() || !std::isfinite(t))
  {
    return -1;
  }
  const auto upper = std::lower_bound(frame_times.begin(), frame_times.end(), t);
  int best = -1;
  double best_gap = tolerance_s;
  auto consider = [&](std::vector<double>::const_iterator it)
  {
    const double gap = std::abs(*it - t);
    if (gap <= best_gap)
    {
      best_gap = gap;
      best = static_cast<int>(it - frame_times.begin());
    }
  };
  if (upper != frame_times.begin())
  {
    consider(upper - 1);
  }
  if (upper != frame_times.end())
  {
    consider(upper);
  }
  return best;
}

std::vector<EvalObject> evalObjects(const std::vector<GroundTruthObject>& ground_truth)
{
  std::vector<EvalObject> out;
  out.reserve(ground_truth.size());
  for (const GroundTruthObject& gt : ground_truth)
  {
    out.push_back(gt.object);
  }
  return out;
}

}  // namespace grid_vision_fusion
