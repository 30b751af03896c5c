#include "grid_vision_fusion/simulation/synthetic_drive.h"

#include <opencv2/imgcodecs.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <random>
#include <sstream>
#include <stdexcept>

#include "grid_vision_fusion/cli/temporary_output.h"
#include "grid_vision_fusion/kitti/kitti_raw.h"
#include "grid_vision_fusion/simulation/synthetic_camera.h"

namespace grid_vision_fusion
{
namespace
{
namespace fs = std::filesystem;

constexpr double kEarthRadiusM = 6378137.0;
constexpr double kGravity = 9.81;
constexpr double kDifferenceStepS = 0.05;  // central differences for accelerations and yaw rates
constexpr double kMaxLabelDepthM = 80.0;   // KITTI labels objects up to about this depth
constexpr double kScanHalfPeriodS = 0.05;  // a 10 Hz revolution around the scan stamp
constexpr double kHalfWheelbaseM = 1.35;   // the ego's wheels on a profiled ground (egoImuPose())
constexpr double kHalfTrackM = 0.8;
constexpr std::uint32_t kInsStream = 0x494E53;  // "INS": the INS error's own random stream
const char* const kCameraName = "image_02";
const char* const kCalibrationFiles[] = {"calib_cam_to_cam.txt", "calib_velo_to_cam.txt",
                                         "calib_imu_to_velo.txt"};

std::string indexName(int index, const char* extension)
{
  std::ostringstream name;
  name << std::setw(10) << std::setfill('0') << index << extension;
  return name.str();
}

std::ofstream openForWriting(const fs::path& path)
{
  std::ofstream file(path);
  if (!file)
  {
    throw std::runtime_error("cannot write " + path.string());
  }
  file << std::setprecision(12);
  return file;
}

void closeChecked(std::ofstream& file, const fs::path& path)
{
  file.close();
  if (!file)
  {
    throw std::runtime_error("error while writing " + path.string());
  }
}

double wrapAngle(double a)
{
  return std::atan2(std::sin(a), std::cos(a));
}

KittiStamp addSeconds(const KittiStamp& base, double seconds)
{
  constexpr std::int64_t kNsPerS = 1000000000;
  const std::int64_t total_ns = base.sec * kNsPerS + static_cast<std::int64_t>(base.nsec) +
                                static_cast<std::int64_t>(std::llround(seconds * 1e9));
  const std::int64_t sec = total_ns >= 0 ? total_ns / kNsPerS : -((-total_ns + kNsPerS - 1) / kNsPerS);
  KittiStamp stamp;
  stamp.sec = sec;
  stamp.nsec = static_cast<std::uint32_t>(total_ns - sec * kNsPerS);
  return stamp;
}

std::string formatStamp(const KittiStamp& stamp)
{
  const std::time_t seconds = static_cast<std::time_t>(stamp.sec);
  std::tm tm{};
  gmtime_r(&seconds, &tm);
  char text[64];
  std::snprintf(text, sizeof(text), "%04d-%02d-%02d %02d:%02d:%02d.%09u", tm.tm_year + 1900, tm.tm_mon + 1,
                tm.tm_mday, tm.tm_hour, tm.tm_min, tm.tm_sec, stamp.nsec);
  return text;
}

/// A ground pose at height z as an isometry (yaw only).
Eigen::Isometry3d groundPose(const Pose2D& pose, double z)
{
  Eigen::Isometry3d iso = Eigen::Isometry3d::Identity();
  iso.translation() << pose.x, pose.y, z;
  iso.linear() = Eigen::AngleAxisd(pose.yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  return iso;
}

bool flatGround(const GroundSurface& ground)
{
  return !ground.profiled() && ground.slope_x == 0.0 && ground.height == 0.0;
}

/// OXTS record of the ego IMU at time t: inverse Mercator around the origin, velocities,
/// accelerations and rates by central differences; on a ground that is not flat the IMU's height,
/// roll and pitch where it stands (egoImuPose()); plus the INS's `error` when the scenario has one.
OxtsRecord oxtsAt(const SyntheticScenario& scenario, double t, double imu_height,
                  const SyntheticDriveOptions& o, const InsErrorSample& error)
{
  const Trajectory& ego = scenario.ego;
  const double scale = mercatorScale(o.origin_lat_deg);
  const double mx0 = scale * kEarthRadiusM * o.origin_lon_deg * M_PI / 180.0;
  const double my0 = scale * kEarthRadiusM * std::log(std::tan((90.0 + o.origin_lat_deg) * M_PI / 360.0));
  Pose2D pose = ego.poseAt(t);
  double height = imu_height, roll = 0.0, pitch = 0.0;
  if (!flatGround(scenario.ground))
  {
    const Eigen::Isometry3d imu = egoImuPose(scenario.ground, pose, imu_height);
    pose.x = imu.translation().x();
    pose.y = imu.translation().y();
    height = imu.translation().z();
    roll = std::atan2(imu.linear()(2, 1), imu.linear()(2, 2));
    pitch = -std::asin(std::clamp(imu.linear()(2, 0), -1.0, 1.0));
  }
  if (scenario.ins_error.enabled())
  {
    pose.x += error.east;
    pose.y += error.north;
    pose.yaw = wrapAngle(pose.yaw + error.yaw);
    height += error.up;
    roll += error.roll;
    pitch += error.pitch;
  }
  OxtsRecord r;
  r.lon = (mx0 + pose.x) * 180.0 / (M_PI * kEarthRadiusM * scale);
  r.lat = 360.0 / M_PI * std::atan(std::exp((my0 + pose.y) / (kEarthRadiusM * scale))) - 90.0;
  r.alt = o.origin_alt_m + height;
  r.roll = roll;
  r.pitch = pitch;
  r.yaw = pose.yaw;
  const Eigen::Vector2d v = ego.velocityAt(t);
  const Eigen::Vector2d heading(std::cos(pose.yaw), std::sin(pose.yaw));
  const Eigen::Vector2d left(-heading.y(), heading.x());
  r.ve = v.x();
  r.vn = v.y();
  r.vf = v.dot(heading);
  r.vl = v.dot(left);
  const Eigen::Vector2d a = (ego.velocityAt(t + kDifferenceStepS) - ego.velocityAt(t - kDifferenceStepS)) /
                            (2.0 * kDifferenceStepS);
  r.ax = r.af = a.dot(heading);
  r.ay = r.al = a.dot(left);
  r.az = r.au = kGravity;
  r.wz = r.wu = wrapAngle(ego.poseAt(t + kDifferenceStepS).yaw - ego.poseAt(t - kDifferenceStepS).yaw) /
                (2.0 * kDifferenceStepS);
  r.pos_accuracy = 0.05;
  r.vel_accuracy = 0.02;
  r.navstat = 4;
  r.numsats = 10;
  r.posmode = r.velmode = r.orimode = 6;
  return r;
}

void writeOxtsLine(std::ofstream& out, const OxtsRecord& r)
{
  const double values[] = {r.lat, r.lon, r.alt, r.roll, r.pitch, r.yaw,          r.vn,          r.ve, r.vf,
                           r.vl,  r.vu,  r.ax,  r.ay,   r.az,    r.af,           r.al,          r.au, r.wx,
                           r.wy,  r.wz,  r.wf,  r.wl,   r.wu,    r.pos_accuracy, r.vel_accuracy};
  out << std::setprecision(14);
  for (double v : values)
  {
    out << v << ' ';
  }
  out << r.navstat << ' ' << r.numsats << ' ' << r.posmode << ' ' << r.velmode << ' ' << r.orimode << '\n';
}

/// A KITTI object label line of `actor` (box in the rectified camera-0 frame).
std::string labelLine(const Actor& actor, const GroundBox& box, const ActorInImage& image,
                      const Eigen::Isometry3d& rect_from_world)
{
  const Eigen::Vector3d location = rect_from_world * Eigen::Vector3d(box.pose.x, box.pose.y, box.base_z);
  const Eigen::Vector3d direction =
      rect_from_world.linear() * Eigen::Vector3d(std::cos(box.pose.yaw), std::sin(box.pose.yaw), 0.0);
  const double ry = wrapAngle(std::atan2(-direction.z(), direction.x()));
  const double alpha = wrapAngle(ry - std::atan2(location.x(), location.z()));
  char line[256];
  std::snprintf(line, sizeof(line),
                "%s %.2f %d %.2f %.2f %.2f %.2f %.2f %.2f %.2f %.2f %.2f %.2f %.2f %.2f\n",
                actor.type.c_str(), image.truncation, image.occlusionLevel(), alpha, image.box.x_min,
                image.box.y_min, image.box.x_max, image.box.y_max, actor.height, actor.width, actor.length,
                location.x(), location.y(), location.z(), ry);
  return line;
}

/// Per actor and frame, what the tracklet file needs.
struct TrackletSample
{
  Eigen::Vector3d bottom_centre_velo;
  double yaw_velo = 0.0;
  int occlusion = 0;
  int truncation = 0;
};

/// The frames of one actor's tracklet: contiguous from first_frame.
struct TrackletTrack
{
  int first_frame = -1;
  std::vector<TrackletSample> samples;
};

void writeTracklets(const fs::path& path, const std::vector<Actor>& actors,
                    const std::vector<TrackletTrack>& tracks)
{
  std::ofstream out = openForWriting(path);
  out << std::setprecision(10);
  out << "<?xml version=\"1.0\" encoding=\"UTF-8\" standalone=\"yes\" ?>\n<!DOCTYPE boost_serialization>\n"
      << "<boost_serialization signature=\"serialization::archive\" version=\"9\">\n"
      << "<tracklets class_id=\"0\" tracking_level=\"0\" version=\"0\">\n"
      << "\t<count>" << actors.size() << "</count>\n\t<item_version>1</item_version>\n";
  for (std::size_t a = 0; a < actors.size(); ++a)
  {
    out << (a == 0 ? "\t<item class_id=\"1\" tracking_level=\"0\" version=\"1\">\n" : "\t<item>\n");
    out << "\t\t<objectType>" << actors[a].type << "</objectType>\n\t\t<h>" << actors[a].height
        << "</h>\n\t\t<w>" << actors[a].width << "</w>\n\t\t<l>" << actors[a].length
        << "</l>\n\t\t<first_frame>" << std::max(tracks[a].first_frame, 0) << "</first_frame>\n";
    out << "\t\t<poses class_id=\"2\" tracking_level=\"0\" version=\"0\">\n\t\t\t<count>"
        << tracks[a].samples.size() << "</count>\n\t\t\t<item_version>2</item_version>\n";
    for (std::size_t f = 0; f < tracks[a].samples.size(); ++f)
    {
      const TrackletSample& s = tracks[a].samples[f];
      out << (a == 0 && f == 0 ? "\t\t\t<item class_id=\"3\" tracking_level=\"0\" version=\"2\">\n"
                               : "\t\t\t<item>\n")
          << "\t\t\t\t<tx>" << s.bottom_centre_velo.x() << "</tx>\n\t\t\t\t<ty>" << s.bottom_centre_velo.y()
          << "</ty>\n\t\t\t\t<tz>" << s.bottom_centre_velo.z()
          << "</tz>\n\t\t\t\t<rx>0</rx>\n\t\t\t\t<ry>0</ry>\n"
          << "\t\t\t\t<rz>" << s.yaw_velo << "</rz>\n\t\t\t\t<state>2</state>\n\t\t\t\t<occlusion>"
          << s.occlusion << "</occlusion>\n\t\t\t\t<occlusion_kf>0</occlusion_kf>\n\t\t\t\t<truncation>"
          << s.truncation
          << "</truncation>\n\t\t\t\t<amt_occlusion>-1</amt_occlusion>\n\t\t\t\t<amt_occlusion_kf>-1</"
             "amt_occlusion_kf>\n"
          << "\t\t\t\t<amt_border_l>-1</amt_border_l>\n\t\t\t\t<amt_border_r>-1</amt_border_r>\n"
          << "\t\t\t\t<amt_border_kf>-1</amt_border_kf>\n\t\t\t</item>\n";
    }
    out << "\t\t</poses>\n\t\t<finished>1</finished>\n\t</item>\n";
  }
  out << "</tracklets>\n</boost_serialization>\n";
  closeChecked(out, path);
}
}  // namespace

void SyntheticDriveOptions::validate() const
{
  if (output_root.empty())
  {
    throw std::invalid_argument("output_root must be given");
  }
  if (calibration_dir.empty())
  {
    throw std::invalid_argument("calibration_dir must be given");
  }
  if (drive_number < 0 || drive_number > 9999)
  {
    throw std::invalid_argument("drive_number must be in [0, 9999], got " + std::to_string(drive_number));
  }
  if (!(lidar_height_m > 0.0))
  {
    throw std::invalid_argument("lidar_height_m must be > 0");
  }
  parseKittiStamp(start_time, "start_time");
}

std::string oxtsDataFormat()
{
  return "lat:   latitude of the oxts-unit (deg)\n"
         "lon:   longitude of the oxts-unit (deg)\n"
         "alt:   altitude of the oxts-unit (m)\n"
         "roll:  roll angle (rad),    0 = level, positive = left side up,      range: -pi   .. +pi\n"
         "pitch: pitch angle (rad),   0 = level, positive = front down,        range: -pi/2 .. +pi/2\n"
         "yaw:   heading (rad),       0 = east,  positive = counter clockwise, range: -pi   .. +pi\n"
         "vn:    velocity towards north (m/s)\n"
         "ve:    velocity towards east (m/s)\n"
         "vf:    forward velocity, i.e. parallel to earth-surface (m/s)\n"
         "vl:    leftward velocity, i.e. parallel to earth-surface (m/s)\n"
         "vu:    upward velocity, i.e. perpendicular to earth-surface (m/s)\n"
         "ax:    acceleration in x, i.e. in direction of vehicle front (m/s^2)\n"
         "ay:    acceleration in y, i.e. in direction of vehicle left (m/s^2)\n"
         "az:    acceleration in z, i.e. in direction of vehicle top (m/s^2)\n"
         "af:    forward acceleration (m/s^2)\n"
         "al:    leftward acceleration (m/s^2)\n"
         "au:    upward acceleration (m/s^2)\n"
         "wx:    angular rate around x (rad/s)\n"
         "wy:    angular rate around y (rad/s)\n"
         "wz:    angular rate around z (rad/s)\n"
         "wf:    angular rate around forward axis (rad/s)\n"
         "wl:    angular rate around leftward axis (rad/s)\n"
         "wu:    angular rate around upward axis (rad/s)\n"
         "pos_accuracy:  velocity accuracy (north/east in m)\n"
         "vel_accuracy:  velocity accuracy (north/east in m/s)\n"
         "navstat:       navigation status (see navstat_to_string)\n"
         "numsats:       number of satellites tracked by primary GPS receiver\n"
         "posmode:       position mode of primary GPS receiver (see gps_mode_to_string)\n"
         "velmode:       velocity mode of primary GPS receiver (see gps_mode_to_string)\n"
         "orimode:       orientation mode of primary GPS receiver (see gps_mode_to_string)\n";
}

SyntheticScenario recordedDriveScenario(const std::string& drive_dir, const KittiRawCalibration& calibration,
                                        const SyntheticScenario& base)
{
  static const std::uint32_t kPalette[] = {0xB03A2E, 0x1F618D, 0x239B56, 0x884EA0, 0xCA6F1E,
                                           0x5D6D7E, 0xD0D3D4, 0x7D6608, 0x2874A6, 0xA04000};
  const std::vector<OxtsRecord> records = readOxtsFolder((fs::path(drive_dir) / "oxts").string());
  const std::vector<Eigen::Isometry3d> imu_poses = oxtsPosesRelativeToFirst(records);
  const std::vector<Tracklet> tracklets =
      readTracklets((fs::path(drive_dir) / "tracklet_labels.xml").string());
  SyntheticScenario scenario = base;
  const double rate = base.frame_rate_hz;
  scenario.duration_s = static_cast<double>(imu_poses.size()) / rate;

  std::vector<double> times;
  std::vector<Pose2D> ego;
  for (std::size_t i = 0; i < imu_poses.size(); ++i)
  {
    const Eigen::Isometry3d& p = imu_poses[i];
    times.push_back(static_cast<double>(i) / rate);
    ego.push_back({p.translation().x(), p.translation().y(), std::atan2(p.linear()(1, 0), p.linear()(0, 0))});
  }
  scenario.ego = Trajectory::posed(times, ego);

  const Eigen::Isometry3d imu_from_velo = calibration.velo_from_imu.inverse();
  scenario.actors.clear();
  for (std::size_t k = 0; k < tracklets.size(); ++k)
  {
    const Tracklet& tracklet = tracklets[k];
    std::vector<double> actor_times;
    std::vector<Pose2D> actor_poses;
    for (std::size_t j = 0; j < tracklet.poses.size(); ++j)
    {
      const std::size_t frame = static_cast<std::size_t>(tracklet.first_frame) + j;
      if (frame >= ego.size())
      {
        throw std::runtime_error(drive_dir + "/tracklet_labels.xml: tracklet " + std::to_string(k) +
                                 " has a pose in frame " + std::to_string(frame) + " but oxts/ has only " +
                                 std::to_string(ego.size()) + " records");
      }
      const TrackletPose& pose = tracklet.poses[j];
      const Eigen::Isometry3d world_from_imu = groundPose(ego[frame], 0.0);
      const Eigen::Vector3d world =
          world_from_imu * (imu_from_velo * Eigen::Vector3d(pose.tx, pose.ty, pose.tz));
      actor_times.push_back(times[frame]);
      actor_poses.push_back({world.x(), world.y(), ego[frame].yaw + pose.rz});
    }
    if (actor_poses.empty())
    {
      continue;
    }
    Actor actor;
    actor.type = tracklet.object_type;
    actor.length = tracklet.l;
    actor.width = tracklet.w;
    actor.height = tracklet.h;
    actor.trajectory = Trajectory::posed(actor_times, actor_poses);
    actor.active_from = actor_times.front();
    actor.active_until = actor_times.back();
    actor.color_rgb = kPalette[k % (sizeof(kPalette) / sizeof(kPalette[0]))];
    actor.shape = base.vehicle_profiles ? profileForType(actor.type) : VehicleShape::kBox;
    actor.glass_transmission = base.glass_transmission;
    scenario.actors.push_back(actor);
  }
  scenario.validate();
  return scenario;
}

namespace
{
/// Where a drive's files go (inside the temporary drive folder) and what every frame needs of
/// the sensor set-up.
struct DriveLayout
{
  fs::path drive_dir, image_dir, velo_dir, oxts_dir, label_dir;
  // Sensor placement: the velodyne `lidar_height_m` above the road, the IMU where the day's
  // calibration puts it relative to the velodyne, the rectified camera-0 frame from the
  // velodyne through R_rect_00 · Tr_velo_to_cam.
  Eigen::Isometry3d imu_from_velo, velo_from_rect;
  double imu_height = 0.0;  ///< of the IMU above the ground [m]
  SyntheticCameraModel camera;
  std::vector<std::uint32_t> actor_colors, scenery_colors;
};

/// Creates the drive's folders, copies the day's calibration files next to it and sets up the
/// sensors. @throws std::runtime_error naming a folder or file that cannot be written.
DriveLayout prepareDrive(const SyntheticScenario& scenario, const SyntheticDriveOptions& options,
                         const KittiRawCalibration& calibration, const fs::path& day_dir,
                         const fs::path& drive_dir)
{
  DriveLayout layout;
  layout.drive_dir = drive_dir;
  layout.image_dir = drive_dir / kCameraName / "data";
  layout.velo_dir = drive_dir / "velodyne_points" / "data";
  layout.oxts_dir = drive_dir / "oxts" / "data";
  layout.label_dir = drive_dir / "label_2";
  std::error_code error;
  for (const fs::path& dir : {layout.image_dir, layout.velo_dir, layout.oxts_dir, layout.label_dir})
  {
    fs::create_directories(dir, error);
    if (error)
    {
      throw std::runtime_error("cannot create " + dir.string() + ": " + error.message());
    }
  }
  for (const char* file : kCalibrationFiles)
  {
    fs::copy_file(fs::path(options.calibration_dir) / file, day_dir / file,
                  fs::copy_options::overwrite_existing, error);
    if (error)
    {
      throw std::runtime_error("cannot copy " + (fs::path(options.calibration_dir) / file).string() + " to " +
                               day_dir.string() + ": " + error.message());
    }
  }
  layout.imu_from_velo = calibration.velo_from_imu.inverse();
  layout.imu_height = options.lidar_height_m - layout.imu_from_velo.translation().z();
  layout.velo_from_rect = calibration.rectifiedFromVelo().inverse();
  layout.camera.projection = calibration.p_rect[2];
  layout.camera.width = static_cast<int>(calibration.image_size[2][0]);
  layout.camera.height = static_cast<int>(calibration.image_size[2][1]);
  for (const auto& actor : scenario.actors)
  {
    layout.actor_colors.push_back(actor.color_rgb);
  }
  for (const auto& box : scenario.scenery)
  {
    layout.scenery_colors.push_back(box.color_rgb);
  }
  return layout;
}

/// The time stamp files of a drive, written frame by frame.
struct StampFiles
{
  explicit StampFiles(const fs::path& drive_dir)
      : paths{drive_dir / kCameraName / "timestamps.txt", drive_dir / "velodyne_points" / "timestamps.txt",
              drive_dir / "velodyne_points" / "timestamps_start.txt",
              drive_dir / "velodyne_points" / "timestamps_end.txt", drive_dir / "oxts" / "timestamps.txt"}
  {
    for (std::size_t i = 0; i < kCount; ++i)
    {
      files[i] = openForWriting(paths[i]);
    }
  }
  /// The stamps of the frame at `t` [s] after `start`.
  void add(const KittiStamp& start, double t, double oxts_delay)
  {
    const KittiStamp stamp = addSeconds(start, t);
    files[0] << formatStamp(stamp) << '\n';
    files[1] << formatStamp(stamp) << '\n';
    files[2] << formatStamp(addSeconds(start, t - kScanHalfPeriodS)) << '\n';
    files[3] << formatStamp(addSeconds(start, t + kScanHalfPeriodS)) << '\n';
    files[4] << formatStamp(addSeconds(start, t + oxts_delay)) << '\n';
  }
  void close()
  {
    for (std::size_t i = 0; i < kCount; ++i)
    {
      closeChecked(files[i], paths[i]);
    }
  }

  static constexpr std::size_t kCount = 5;  ///< image, scan, scan start, scan end, OXTS
  fs::path paths[kCount];
  std::ofstream files[kCount];
};

/// The lidar scan of one frame to velodyne_points/data. Returns its number of points.
std::size_t writeScan(const SceneSnapshot& scene, const Eigen::Isometry3d& world_from_velo,
                      const LidarConfig& lidar, std::mt19937& rng, const fs::path& path)
{
  const std::vector<LidarPoint> scan = simulateLidarScan(scene, world_from_velo, lidar, rng);
  std::ofstream out(path, std::ios::binary);
  out.write(reinterpret_cast<const char*>(scan.data()),
            static_cast<std::streamsize>(scan.size() * sizeof(LidarPoint)));
  closeChecked(out, path);
  return scan.size();
}

/// The label_2 file of one frame (the actors in the image up to kMaxLabelDepthM) and the
/// frame's tracklet samples of the active actors. Returns the number of label lines.
std::size_t writeLabels(const SyntheticScenario& scenario, const SceneSnapshot& scene,
                        const RenderedImage& image, const Eigen::Isometry3d& world_from_velo,
                        const Eigen::Isometry3d& rect_from_world, int frame, const fs::path& label_path,
                        std::vector<TrackletTrack>& tracklets)
{
  const Eigen::Isometry3d velo_from_world = world_from_velo.inverse();
  std::ofstream labels = openForWriting(label_path);
  std::size_t lines = 0;
  for (std::size_t a = 0; a < scenario.actors.size(); ++a)
  {
    const GroundBox& box = scene.actorBoxes()[a];
    const ActorInImage& seen = image.actors[a];
    const Eigen::Vector3d bottom(box.pose.x, box.pose.y, box.base_z);
    const Eigen::Vector3d centre = rect_from_world * bottom;
    if (seen.in_view && seen.silhouette_pixels > 0 && centre.z() > 0.0 && centre.z() <= kMaxLabelDepthM)
    {
      labels << labelLine(scenario.actors[a], box, seen, rect_from_world);
      ++lines;
    }
    if (!scene.actorActive(a))
    {
      continue;
    }
    TrackletSample sample;
    sample.bottom_centre_velo = velo_from_world * bottom;
    const Eigen::Vector3d heading =
        velo_from_world.linear() * Eigen::Vector3d(std::cos(box.pose.yaw), std::sin(box.pose.yaw), 0.0);
    sample.yaw_velo = std::atan2(heading.y(), heading.x());
    sample.occlusion = std::min(seen.occlusionLevel(), 2);
    sample.truncation = !seen.in_view ? 2 : seen.truncation > 0.05 ? 1 : 0;
    if (tracklets[a].first_frame < 0)
    {
      tracklets[a].first_frame = frame;
    }
    tracklets[a].samples.push_back(sample);
  }
  closeChecked(labels, label_path);
  return lines;
}

/// Scan, image, labels and OXTS record of one frame; the tracklet samples to `tracklets`.
void writeFrame(const SyntheticScenario& scenario, const SyntheticDriveOptions& options,
                const DriveLayout& layout, int frame, const InsErrorSample& ins_error, std::mt19937& rng,
                std::vector<TrackletTrack>& tracklets, SyntheticDriveSummary& summary)
{
  const double t = scenario.frameTime(frame);
  const Eigen::Isometry3d world_from_imu =
      egoImuPose(scenario.ground, scenario.ego.poseAt(t), layout.imu_height);
  const Eigen::Isometry3d world_from_velo = world_from_imu * layout.imu_from_velo;
  const Eigen::Isometry3d world_from_rect = world_from_velo * layout.velo_from_rect;
  const Eigen::Isometry3d rect_from_world = world_from_rect.inverse();
  SceneSnapshot scene(scenario.actors, scenario.scenery, t, scenario.ground);
  scene.cullBeyond(world_from_velo.translation().head<2>(),
                   std::max(scenario.lidar.max_range, layout.camera.far_m));

  summary.lidar_points +=
      writeScan(scene, world_from_velo, scenario.lidar, rng, layout.velo_dir / indexName(frame, ".bin"));

  const RenderedImage image = renderCamera(scene, layout.actor_colors, layout.scenery_colors, world_from_rect,
                                           layout.camera, scenario.road);
  const fs::path image_path = layout.image_dir / indexName(frame, ".png");
  if (!cv::imwrite(image_path.string(), image.bgr))
  {
    throw std::runtime_error("cannot write " + image_path.string());
  }
  summary.labels += writeLabels(scenario, scene, image, world_from_velo, rect_from_world, frame,
                                layout.label_dir / indexName(frame, ".txt"), tracklets);

  const fs::path path = layout.oxts_dir / indexName(frame, ".txt");
  std::ofstream out = openForWriting(path);
  writeOxtsLine(out, oxtsAt(scenario, t + scenario.oxts_delay_s, layout.imu_height, options, ins_error));
  closeChecked(out, path);
}
}  // namespace

std::vector<InsErrorSample> sampleInsErrors(const InsError& model, std::uint32_t seed,
                                            const std::vector<double>& times)
{
  std::vector<InsErrorSample> errors(times.size());
  if (!model.enabled())
  {
    return errors;
  }
  std::seed_seq seeds{seed, kInsStream};
  std::mt19937 rng(seeds);
  std::normal_distribution<double> normal(0.0, 1.0);
  double east = 0.0, north = 0.0, walk = 0.0;
  for (std::size_t k = 0; k < times.size(); ++k)
  {
    // Six draws per record, whatever is enabled: the stream of one error does not depend on the others.
    double draws[6];
    for (double& draw : draws)
    {
      draw = normal(rng);
    }
    const double dt = k == 0 ? 0.0 : times[k] - times[k - 1];
    const double keep =
        k > 0 && model.position_correlation_s > 0.0 ? std::exp(-dt / model.position_correlation_s) : 0.0;
    const double fresh = std::sqrt(1.0 - keep * keep) * model.position_std;
    east = keep * east + fresh * draws[0];
    north = keep * north + fresh * draws[1];
    walk += model.yaw_walk_std * std::sqrt(dt) * draws[3];
    errors[k] = {east,
                 north,
                 model.height_std * draws[2],
                 model.yaw_drift_rate * times[k] + walk,
                 model.roll_std * draws[4],
                 model.pitch_std * draws[5]};
  }
  return errors;
}

Eigen::Isometry3d egoImuPose(const GroundSurface& ground, const Pose2D& pose, double imu_height)
{
  if (flatGround(ground))
  {
    return groundPose(pose, imu_height);
  }
  const Eigen::Vector2d at(pose.x, pose.y);
  const Eigen::Vector2d forward(std::cos(pose.yaw), std::sin(pose.yaw));
  const Eigen::Vector2d left(-forward.y(), forward.x());
  const auto wheel = [&](double along, double across)
  {
    const Eigen::Vector2d p = at + along * forward + across * left;
    return ground.z(p.x(), p.y());
  };
  const double front_left = wheel(kHalfWheelbaseM, kHalfTrackM);
  const double front_right = wheel(kHalfWheelbaseM, -kHalfTrackM);
  const double rear_left = wheel(-kHalfWheelbaseM, kHalfTrackM);
  const double rear_right = wheel(-kHalfWheelbaseM, -kHalfTrackM);
  const double roll = std::atan2(front_left + rear_left - front_right - rear_right, 4.0 * kHalfTrackM);
  const double pitch = std::atan2(rear_left + rear_right - front_left - front_right, 4.0 * kHalfWheelbaseM);
  Eigen::Isometry3d iso = Eigen::Isometry3d::Identity();
  iso.linear() =
      (Eigen::AngleAxisd(pose.yaw, Eigen::Vector3d::UnitZ()) *
       Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitY()) * Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitX()))
          .toRotationMatrix();
  const double z = (front_left + front_right + rear_left + rear_right) / 4.0;
  iso.translation() =
      Eigen::Vector3d(pose.x, pose.y, z) + iso.linear() * Eigen::Vector3d(0.0, 0.0, imu_height);
  return iso;
}

SyntheticDriveSummary writeSyntheticDrive(const SyntheticScenario& scenario,
                                          const SyntheticDriveOptions& options,
                                          const std::function<void(int, int)>& progress)
{
  scenario.validate();
  options.validate();
  const KittiRawCalibration calibration = KittiRawCalibration::readDirectory(options.calibration_dir);

  std::ostringstream drive_name;
  drive_name << options.date << "_drive_" << std::setw(4) << std::setfill('0') << options.drive_number
             << "_sync";
  const fs::path day_dir = fs::path(options.output_root) / options.date;
  // The drive is written into <drive>.tmp and moved in place when complete: a failure leaves
  // neither a partial drive nor the temporary behind, and a drive already there untouched.
  TemporaryOutput output((day_dir / drive_name.str()).string());
  const DriveLayout layout = prepareDrive(scenario, options, calibration, day_dir, output.temporary());

  const int frames =
      options.max_frames >= 0 ? std::min(options.max_frames, scenario.frameCount()) : scenario.frameCount();
  const KittiStamp start = parseKittiStamp(options.start_time, "start_time");
  StampFiles stamps(layout.drive_dir);
  {
    const fs::path path = layout.drive_dir / "oxts" / "dataformat.txt";
    std::ofstream format = openForWriting(path);
    format << oxtsDataFormat();
    closeChecked(format, path);
  }
  std::vector<double> oxts_times;
  for (int frame = 0; frame < frames; ++frame)
  {
    oxts_times.push_back(scenario.frameTime(frame) + scenario.oxts_delay_s);
  }
  const std::vector<InsErrorSample> ins_errors =
      sampleInsErrors(scenario.ins_error, scenario.seed, oxts_times);

  std::mt19937 rng(scenario.seed);
  SyntheticDriveSummary summary;
  summary.drive_dir = output.path();
  summary.frames = frames;
  std::vector<TrackletTrack> tracklets(scenario.actors.size());
  for (int frame = 0; frame < frames; ++frame)
  {
    writeFrame(scenario, options, layout, frame, ins_errors[static_cast<std::size_t>(frame)], rng, tracklets,
               summary);
    stamps.add(start, scenario.frameTime(frame), scenario.oxts_delay_s);
    if (progress)
    {
      progress(frame + 1, frames);
    }
  }
  stamps.close();
  writeTracklets(layout.drive_dir / "tracklet_labels.xml", scenario.actors, tracklets);
  output.commit();
  return summary;
}

}  // namespace grid_vision_fusion
