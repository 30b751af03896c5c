#include "grid_vision_fusion/evaluation/kitti_ground_truth.h"

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <cstdio>
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
