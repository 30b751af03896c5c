#include "grid_vision_fusion/kitti/kitti_raw.h"

#include <boost/property_tree/ptree.hpp>
#include <boost/property_tree/xml_parser.hpp>

#include <cmath>
#include <ctime>
#include <fstream>
#include <iomanip>
#include <limits>
#include <sstream>
#include <stdexcept>

namespace grid_vision_fusion
{
namespace
{
constexpr double kEarthRadiusM = 6378137.0;
constexpr std::size_t kOxtsFields = 30;

std::string oxtsPath(const std::string& oxts_dir, std::size_t index)
{
  std::ostringstream path;
  path << oxts_dir << "/data/" << std::setw(10) << std::setfill('0') << index << ".txt";
  return path.str();
}

template <typename T>
T child(const boost::property_tree::ptree& node, const std::string& name, const std::string& where)
{
  const auto value = node.get_optional<T>(name);
  if (!value)
  {
    throw std::runtime_error(where + ": missing or malformed <" + name + ">");
  }
  return *value;
}
}  // namespace

OxtsRecord parseOxtsLine(const std::string& line, const std::string& source)
{
  std::istringstream in(line);
  std::vector<double> v;
  double value = 0.0;
  while (in >> value)
  {
    v.push_back(value);
  }
  if (!in.eof() || v.size() != kOxtsFields)
  {
    throw std::runtime_error(source + ": an OXTS record needs " + std::to_string(kOxtsFields) +
                             " numbers, read " + std::to_string(v.size()) +
                             (in.eof() ? "" : " before a non-number"));
  }
  OxtsRecord r;
  double* doubles[] = {&r.lat, &r.lon, &r.alt,          &r.roll,        &r.pitch, &r.yaw, &r.vn,
                       &r.ve,  &r.vf,  &r.vl,           &r.vu,          &r.ax,    &r.ay,  &r.az,
                       &r.af,  &r.al,  &r.au,           &r.wx,          &r.wy,    &r.wz,  &r.wf,
                       &r.wl,  &r.wu,  &r.pos_accuracy, &r.vel_accuracy};
  std::size_t i = 0;
  for (double* field : doubles)
  {
    *field = v[i++];
  }
  int* ints[] = {&r.navstat, &r.numsats, &r.posmode, &r.velmode, &r.orimode};
  const char* const int_names[] = {"navstat", "numsats", "posmode", "velmode", "orimode"};
  for (std::size_t k = 0; k < 5; ++k, ++i)
  {
    if (!(v[i] == std::floor(v[i]) && std::abs(v[i]) <= std::numeric_limits<int>::max()))
    {
      std::ostringstream what;
      what << source << ": OXTS field " << i + 1 << " (" << int_names[k] << ") is not an integer: " << v[i];
      throw std::runtime_error(what.str());
    }
    *ints[k] = static_cast<int>(v[i]);
  }
  return r;
}

std::vector<OxtsRecord> readOxtsFolder(const std::string& oxts_dir)
{
  std::vector<OxtsRecord> records;
  for (std::size_t index = 0;; ++index)
  {
    const std::string path = oxtsPath(oxts_dir, index);
    std::ifstream file(path);
    if (!file)
    {
      break;
    }
    std::string line;
    std::getline(file, line);
    records.push_back(parseOxtsLine(line, path));
  }
  if (records.empty())
  {
    throw std::runtime_error("no OXTS record found: " + oxtsPath(oxts_dir, 0) + " cannot be read");
  }
  return records;
}

double mercatorScale(double lat0_deg)
{
  return std::cos(lat0_deg * M_PI / 180.0);
}

Eigen::Isometry3d oxtsToMercatorPose(const OxtsRecord& record, double scale)
{
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.translation() << scale * record.lon * M_PI * kEarthRadiusM / 180.0,
      scale * kEarthRadiusM * std::log(std::tan((90.0 + record.lat) * M_PI / 360.0)), record.alt;
  pose.linear() = (Eigen::AngleAxisd(record.yaw, Eigen::Vector3d::UnitZ()) *
                   Eigen::AngleAxisd(record.pitch, Eigen::Vector3d::UnitY()) *
                   Eigen::AngleAxisd(record.roll, Eigen::Vector3d::UnitX()))
                      .toRotationMatrix();
  return pose;
}

std::vector<Eigen::Isometry3d> alongHeadingPoses(const std::vector<Eigen::Isometry3d>& world_from_imu)
{
  std::vector<Eigen::Isometry3d> poses = world_from_imu;
  for (std::size_t i = 1; i < poses.size(); ++i)
  {
    const Eigen::Vector3d heading =
        (world_from_imu[i - 1].linear().col(0) + world_from_imu[i].linear().col(0)).normalized();
    const Eigen::Vector3d step = world_from_imu[i].translation() - world_from_imu[i - 1].translation();
    poses[i].translation() = poses[i - 1].translation() + step.dot(heading) * heading;
  }
  return poses;
}

std::vector<Eigen::Isometry3d> oxtsPosesRelativeToFirst(const std::vector<OxtsRecord>& records)
{
  std::vector<Eigen::Isometry3d> poses;
  if (records.empty())
  {
    return poses;
  }
  const double scale = mercatorScale(records.front().lat);
  const Eigen::Isometry3d first_inverse = oxtsToMercatorPose(records.front(), scale).inverse();
  poses.reserve(records.size());
  for (const auto& record : records)
  {
    poses.push_back(first_inverse * oxtsToMercatorPose(record, scale));
  }
  return poses;
}

KittiStamp parseKittiStamp(const std::string& text, const std::string& source)
{
  std::tm tm{};
  std::istringstream in(text);
  in >> std::get_time(&tm, "%Y-%m-%d %H:%M:%S");
  char dot = 0;
  std::string fraction;
  if (in.fail() || !(in >> dot) || dot != '.' || !(in >> fraction) || fraction.empty() ||
      fraction.size() > 9 || fraction.find_first_not_of("0123456789") != std::string::npos)
  {
    throw std::runtime_error(source + ": malformed time stamp \"" + text +
                             "\" (want YYYY-MM-DD hh:mm:ss.fffffffff)");
  }
  fraction.resize(9, '0');
  KittiStamp stamp;
  stamp.sec = static_cast<std::int64_t>(timegm(&tm));
  stamp.nsec = static_cast<std::uint32_t>(std::stoul(fraction));
  return stamp;
}

std::vector<KittiStamp> readTimestamps(const std::string& path)
{
  std::ifstream file(path);
  if (!file)
  {
    throw std::runtime_error("cannot read timestamps file " + path);
  }
  return parseTimestamps(file, path);
}

std::vector<KittiStamp> parseTimestamps(std::istream& input, const std::string& source)
{
  std::vector<KittiStamp> stamps;
  std::string line;
  for (int number = 1; std::getline(input, line); ++number)
  {
    if (line.find_first_not_of(" \t\r") == std::string::npos)
    {
      continue;
    }
    stamps.push_back(parseKittiStamp(line, source + ":" + std::to_string(number)));
  }
  return stamps;
}

std::vector<Tracklet> readTracklets(const std::string& path)
{
  std::ifstream file(path);
  if (!file)
  {
    throw std::runtime_error("cannot parse tracklet file " + path + ": cannot open file");
  }
  return parseTracklets(file, path);
}

std::vector<Tracklet> parseTracklets(std::istream& input, const std::string& path)
{
  boost::property_tree::ptree tree;
  try
  {
    boost::property_tree::read_xml(input, tree);
  }
  catch (const boost::property_tree::xml_parser_error& e)
  {
    throw std::runtime_error("cannot parse tracklet file " + path + ": " + e.what());
  }
  const auto root = tree.get_child_optional("boost_serialization.tracklets");
  if (!root)
  {
    throw std::runtime_error(path + ": no <boost_serialization><tracklets> element");
  }
  std::vector<Tracklet> tracklets;
  const auto count = child<std::size_t>(*root, "count", path);
  for (const auto& [name, item] : *root)
  {
    if (name != "item")
    {
      continue;
    }
    const std::string where = path + ": tracklet " + std::to_string(tracklets.size());
    Tracklet tracklet;
    tracklet.object_type = child<std::string>(item, "objectType", where);
    tracklet.h = child<double>(item, "h", where);
    tracklet.w = child<double>(item, "w", where);
    tracklet.l = child<double>(item, "l", where);
    tracklet.first_frame = child<int>(item, "first_frame", where);
    const auto poses = item.get_child_optional("poses");
    if (!poses)
    {
      throw std::runtime_error(where + ": missing <poses>");
    }
    for (const auto& [pose_name, pose_item] : *poses)
    {
      if (pose_name != "item")
      {
        continue;
      }
      const std::string pose_where = where + " pose " + std::to_string(tracklet.poses.size());
      TrackletPose pose;
      pose.tx = child<double>(pose_item, "tx", pose_where);
      pose.ty = child<double>(pose_item, "ty", pose_where);
      pose.tz = child<double>(pose_item, "tz", pose_where);
      pose.rx = child<double>(pose_item, "rx", pose_where);
      pose.ry = child<double>(pose_item, "ry", pose_where);
      pose.rz = child<double>(pose_item, "rz", pose_where);
      pose.state = child<int>(pose_item, "state", pose_where);
      pose.occlusion = child<int>(pose_item, "occlusion", pose_where);
      pose.truncation = child<int>(pose_item, "truncation", pose_where);
      tracklet.poses.push_back(pose);
    }
    const auto pose_count = child<std::size_t>(*poses, "count", where + " poses");
    if (pose_count != tracklet.poses.size())
    {
      throw std::runtime_error(where + ": <count> says " + std::to_string(pose_count) + " poses, found " +
                               std::to_string(tracklet.poses.size()));
    }
    tracklets.push_back(std::move(tracklet));
  }
  if (count != tracklets.size())
  {
    throw std::runtime_error(path + ": <count> says " + std::to_string(count) + " tracklets, found " +
                             std::to_string(tracklets.size()));
  }
  return tracklets;
}

}  // namespace grid_vision_fusion
