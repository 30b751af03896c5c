#include "grid_vision_fusion/simulation/synthetic_drive.h"

#include <opencv2/imgcodecs.hpp>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iomanip>
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

/// OXTS record of the ego IMU at time t: inverse Mercator around the origin, velocities,
/// accelerations and rates by central differences.
OxtsRecord oxtsAt(const Trajectory& ego, double t, double imu_height, const SyntheticDriveOptions& o)
{
  const double scale = mercatorScale(o.origin_lat_deg);
  const double mx0 = scale * kEarthRadiusM * o.origin_lon_deg * M_PI / 180.0;
  const double my0 = scale * kEarthRadiusM * std::log(std::tan((90.0 + o.origin_lat_deg) * M_PI / 360.0));
  const Pose2D pose = ego.poseAt(t);
  OxtsRecord r;
  r.lon = (mx0 + pose.x) * 180.0 / (M_PI * kEarthRadiusM * scale);
  r.lat = 360.0 / M_PI * std::atan(std::exp((my0 + pose.y) / (kEarthRadiusM * scale))) - 90.0;
  r.alt = o.origin_alt_m + imu_height;
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
  const Eigen::Vector3d location = rect_from_world * Eigen::Vector3d(box.pose.x, box.pose.y, 0.0);
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
    scenario.actors.push_back(actor);
  }
  scenario.validate();
  return scenario;
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
  const fs::path drive_dir = output.temporary();
  const fs::path image_dir = drive_dir / kCameraName / "data";
  const fs::path velo_dir = drive_dir / "velodyne_points" / "data";
  const fs::path oxts_dir = drive_dir / "oxts" / "data";
  const fs::path label_dir = drive_dir / "label_2";
  std::error_code error;
  for (const fs::path& dir : {image_dir, velo_dir, oxts_dir, label_dir})
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

  // Sensor placement: the velodyne `lidar_height_m` above the road, the IMU where the day's
  // calibration puts it relative to the velodyne, the rectified camera-0 frame from the
  // velodyne through R_rect_00 · Tr_velo_to_cam.
  const Eigen::Isometry3d imu_from_velo = calibration.velo_from_imu.inverse();
  const double imu_height = options.lidar_height_m - imu_from_velo.translation().z();
  const Eigen::Isometry3d velo_from_rect = calibration.rectifiedFromVelo().inverse();
  SyntheticCameraModel camera;
  camera.projection = calibration.p_rect[2];
  camera.width = static_cast<int>(calibration.image_size[2][0]);
  camera.height = static_cast<int>(calibration.image_size[2][1]);
  std::vector<std::uint32_t> actor_colors, scenery_colors;
  for (const auto& actor : scenario.actors)
  {
    actor_colors.push_back(actor.color_rgb);
  }
  for (const auto& box : scenario.scenery)
  {
    scenery_colors.push_back(box.color_rgb);
  }

  const int frames =
      options.max_frames >= 0 ? std::min(options.max_frames, scenario.frameCount()) : scenario.frameCount();
  const KittiStamp start = parseKittiStamp(options.start_time, "start_time");
  const fs::path image_stamps_path = drive_dir / kCameraName / "timestamps.txt";
  const fs::path velo_stamps_path = drive_dir / "velodyne_points" / "timestamps.txt";
  const fs::path velo_start_path = drive_dir / "velodyne_points" / "timestamps_start.txt";
  const fs::path velo_end_path = drive_dir / "velodyne_points" / "timestamps_end.txt";
  const fs::path oxts_stamps_path = drive_dir / "oxts" / "timestamps.txt";
  std::ofstream image_stamps = openForWriting(image_stamps_path);
  std::ofstream velo_stamps = openForWriting(velo_stamps_path);
  std::ofstream velo_start = openForWriting(velo_start_path);
  std::ofstream velo_end = openForWriting(velo_end_path);
  std::ofstream oxts_stamps = openForWriting(oxts_stamps_path);
  {
    const fs::path path = drive_dir / "oxts" / "dataformat.txt";
    std::ofstream format = openForWriting(path);
    format << oxtsDataFormat();
    closeChecked(format, path);
  }

  std::mt19937 rng(scenario.seed);
  SyntheticDriveSummary summary;
  summary.drive_dir = output.path();
  summary.frames = frames;
  std::vector<TrackletTrack> tracklets(scenario.actors.size());
  for (int frame = 0; frame < frames; ++frame)
  {
    const double t = scenario.frameTime(frame);
    const Eigen::Isometry3d world_from_imu = groundPose(scenario.ego.poseAt(t), imu_height);
    const Eigen::Isometry3d world_from_velo = world_from_imu * imu_from_velo;
    const Eigen::Isometry3d world_from_rect = world_from_velo * velo_from_rect;
    const Eigen::Isometry3d velo_from_world = world_from_velo.inverse();
    const Eigen::Isometry3d rect_from_world = world_from_rect.inverse();
    SceneSnapshot scene(scenario.actors, scenario.scenery, t);
    scene.cullBeyond(world_from_velo.translation().head<2>(),
                     std::max(scenario.lidar.max_range, camera.far_m));

    // Lidar scan.
    const std::vector<LidarPoint> scan = simulateLidarScan(scene, world_from_velo, scenario.lidar, rng);
    {
      const fs::path path = velo_dir / indexName(frame, ".bin");
      std::ofstream out(path, std::ios::binary);
      out.write(reinterpret_cast<const char*>(scan.data()),
                static_cast<std::streamsize>(scan.size() * sizeof(LidarPoint)));
      closeChecked(out, path);
      summary.lidar_points += scan.size();
    }

    // Camera image and labels.
    const RenderedImage image =
        renderCamera(scene, actor_colors, scenery_colors, world_from_rect, camera, scenario.road);
    const fs::path image_path = image_dir / indexName(frame, ".png");
    if (!cv::imwrite(image_path.string(), image.bgr))
    {
      throw std::runtime_error("cannot write " + image_path.string());
    }
    const fs::path label_path = label_dir / indexName(frame, ".txt");
    std::ofstream labels = openForWriting(label_path);
    for (std::size_t a = 0; a < scenario.actors.size(); ++a)
    {
      const GroundBox& box = scene.actorBoxes()[a];
      const ActorInImage& seen = image.actors[a];
      const Eigen::Vector3d centre = rect_from_world * Eigen::Vector3d(box.pose.x, box.pose.y, 0.0);
      if (seen.in_view && seen.silhouette_pixels > 0 && centre.z() > 0.0 && centre.z() <= kMaxLabelDepthM)
      {
        labels << labelLine(scenario.actors[a], box, seen, rect_from_world);
        ++summary.labels;
      }
      if (!scene.actorActive(a))
      {
        continue;
      }
      TrackletSample sample;
      sample.bottom_centre_velo = velo_from_world * Eigen::Vector3d(box.pose.x, box.pose.y, 0.0);
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

    // OXTS and time stamps.
    {
      const fs::path path = oxts_dir / indexName(frame, ".txt");
      std::ofstream out = openForWriting(path);
      writeOxtsLine(out, oxtsAt(scenario.ego, t + scenario.oxts_delay_s, imu_height, options));
      closeChecked(out, path);
    }
    const KittiStamp stamp = addSeconds(start, t);
    image_stamps << formatStamp(stamp) << '\n';
    velo_stamps << formatStamp(stamp) << '\n';
    velo_start << formatStamp(addSeconds(start, t - kScanHalfPeriodS)) << '\n';
    velo_end << formatStamp(addSeconds(start, t + kScanHalfPeriodS)) << '\n';
    oxts_stamps << formatStamp(addSeconds(start, t + scenario.oxts_delay_s)) << '\n';
    if (progress)
    {
      progress(frame + 1, frames);
    }
  }
  closeChecked(image_stamps, image_stamps_path);
  closeChecked(velo_stamps, velo_stamps_path);
  closeChecked(velo_start, velo_start_path);
  closeChecked(velo_end, velo_end_path);
  closeChecked(oxts_stamps, oxts_stamps_path);
  writeTracklets(drive_dir / "tracklet_labels.xml", scenario.actors, tracklets);
  output.commit();
  return summary;
}

}  // namespace grid_vision_fusion
