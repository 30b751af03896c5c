#include "grid_vision_fusion/simulation/synthetic_scenario.h"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <sstream>
#include <stdexcept>

namespace grid_vision_fusion
{
namespace
{
template <typename T>
T get(const YAML::Node& node, const std::string& key, const std::string& where)
{
  if (!node[key])
  {
    throw std::runtime_error(where + ": missing key '" + key + "'");
  }
  try
  {
    return node[key].as<T>();
  }
  catch (const YAML::Exception& e)
  {
    throw std::runtime_error(where + ": key '" + key + "' has the wrong type (" + e.msg + ")");
  }
}

template <typename T>
void getOptional(const YAML::Node& node, const std::string& key, const std::string& where, T& value)
{
  if (node[key])
  {
    value = get<T>(node, key, where);
  }
}

Pose2D parsePose(const YAML::Node& node, const std::string& where)
{
  Pose2D pose;
  pose.x = get<double>(node, "x", where);
  pose.y = get<double>(node, "y", where);
  getOptional(node, "yaw", where, pose.yaw);
  return pose;
}

Trajectory parseMotion(const YAML::Node& node, const std::string& where)
{
  const int kinds = (node["parked"] ? 1 : 0) + (node["waypoints"] ? 1 : 0) + (node["constant_turn"] ? 1 : 0);
  if (kinds != 1)
  {
    throw std::runtime_error(where + ": give exactly one of 'parked', 'waypoints', 'constant_turn'");
  }
  if (node["parked"])
  {
    return Trajectory::parked(parsePose(node["parked"], where + ".parked"));
  }
  if (node["constant_turn"])
  {
    const YAML::Node& turn = node["constant_turn"];
    return Trajectory::constantTurn(parsePose(turn, where + ".constant_turn"),
                                    get<double>(turn, "speed", where + ".constant_turn"),
                                    get<double>(turn, "yaw_rate", where + ".constant_turn"));
  }
  // [t, x, y] (the yaw follows the path) or, in every waypoint, [t, x, y, yaw] (the yaw is given,
  // e.g. for reversing: the heading stays opposite to the motion).
  std::vector<Eigen::Vector3d> points;
  std::vector<double> times;
  std::vector<Pose2D> poses;
  std::size_t width = 0;  // 3 or 4 values per waypoint, as the first one has
  for (const auto& p : node["waypoints"])
  {
    std::vector<double> values;
    try
    {
      values = p.as<std::vector<double>>();
    }
    catch (const YAML::Exception&)
    {
    }
    if (width == 0 && (values.size() == 3 || values.size() == 4))
    {
      width = values.size();
    }
    if (width == 0 || values.size() != width)
    {
      throw std::runtime_error(where + ".waypoints[" + std::to_string(points.size() + poses.size()) +
                               "]: every waypoint is [t, x, y], or every one [t, x, y, yaw]");
    }
    if (values.size() == 4)
    {
      times.push_back(values[0]);
      poses.push_back({values[1], values[2], values[3]});
    }
    else
    {
      points.emplace_back(values[0], values[1], values[2]);
    }
  }
  double initial_yaw = 0.0;
  getOptional(node, "yaw", where, initial_yaw);
  try
  {
    return poses.empty() ? Trajectory::waypoints(points, initial_yaw) : Trajectory::posed(times, poses);
  }
  catch (const std::invalid_argument& e)
  {
    throw std::runtime_error(where + ".waypoints: " + e.what());
  }
}

std::uint32_t colorOr(const YAML::Node& node, const std::string& where, std::uint32_t fallback)
{
  if (!node["color"])
  {
    return fallback;
  }
  try
  {
    return parseColor(get<std::string>(node, "color", where));
  }
  catch (const std::invalid_argument& e)
  {
    throw std::runtime_error(where + ": " + e.what());
  }
}

/// Throws when `node` has a key outside `known` (a misspelt key would otherwise be ignored).
void rejectUnknownKeys(const YAML::Node& node, const std::vector<std::string>& known,
                       const std::string& where)
{
  if (!node.IsMap())
  {
    throw std::runtime_error(where + ": expected a mapping");
  }
  for (const auto& entry : node)
  {
    const std::string key = entry.first.as<std::string>();
    if (std::find(known.begin(), known.end(), key) == known.end())
    {
      std::string list;
      for (const std::string& k : known)
      {
        list += (list.empty() ? "" : ", ") + k;
      }
      throw std::runtime_error(where + ": unknown key '" + key + "' (known: " + list + ")");
    }
  }
}

VehicleShape parseShape(const YAML::Node& node, const std::string& key, const std::string& where,
                        bool van_allowed)
{
  const std::string name = get<std::string>(node, key, where);
  for (VehicleShape shape : {VehicleShape::kBox, VehicleShape::kCar, VehicleShape::kVan})
  {
    if (name == vehicleShapeName(shape) && (van_allowed || shape != VehicleShape::kVan))
    {
      return shape;
    }
  }
  throw std::runtime_error(where + ": " + key + " \"" + name + "\" is not one of " +
                           (van_allowed ? "box, car, van" : "box, car"));
}

void parseGround(const YAML::Node& node, const std::string& where, GroundSurface& ground)
{
  rejectUnknownKeys(
      node, {"slope", "camber", "kerb_height", "verge_rise_left", "verge_rise_right", "verge_width"}, where);
  getOptional(node, "slope", where, ground.slope_x);
  getOptional(node, "camber", where, ground.camber);
  getOptional(node, "kerb_height", where, ground.kerb_height);
  getOptional(node, "verge_rise_left", where, ground.verge_rise_left);
  getOptional(node, "verge_rise_right", where, ground.verge_rise_right);
  getOptional(node, "verge_width", where, ground.verge_width);
}

void parseInsError(const YAML::Node& node, const std::string& where, InsError& error)
{
  rejectUnknownKeys(node,
                    {"position_std", "position_correlation", "height_std", "yaw_drift_rate", "yaw_walk_std",
                     "roll_std", "pitch_std"},
                    where);
  getOptional(node, "position_std", where, error.position_std);
  getOptional(node, "position_correlation", where, error.position_correlation_s);
  getOptional(node, "height_std", where, error.height_std);
  getOptional(node, "yaw_drift_rate", where, error.yaw_drift_rate);
  getOptional(node, "yaw_walk_std", where, error.yaw_walk_std);
  getOptional(node, "roll_std", where, error.roll_std);
  getOptional(node, "pitch_std", where, error.pitch_std);
}

/// The world's settings: road, ground, vehicle shapes, INS error, lidar.
void parseSettings(const YAML::Node& root, const std::string& path, SyntheticScenario& scenario)
{
  if (const YAML::Node road = root["road"])
  {
    getOptional(road, "center_y", path + ": road", scenario.road.center_y);
    getOptional(road, "half_width", path + ": road", scenario.road.half_width);
    getOptional(road, "lane_width", path + ": road", scenario.road.lane_width);
  }
  scenario.ground.center_y = scenario.road.center_y;
  scenario.ground.half_width = scenario.road.half_width;
  if (const YAML::Node ground = root["ground"])
  {
    parseGround(ground, path + ": ground", scenario.ground);
  }
  if (root["vehicle_shape"])
  {
    scenario.vehicle_profiles = parseShape(root, "vehicle_shape", path, false) == VehicleShape::kCar;
  }
  getOptional(root, "glass_transmission", path, scenario.glass_transmission);
  if (const YAML::Node ins = root["ins_error"])
  {
    parseInsError(ins, path + ": ins_error", scenario.ins_error);
  }
  if (const YAML::Node lidar = root["lidar"])
  {
    const std::string where = path + ": lidar";
    getOptional(lidar, "azimuth_steps", where, scenario.lidar.azimuth_steps);
    getOptional(lidar, "range_noise_std", where, scenario.lidar.range_noise_std);
    getOptional(lidar, "dropout", where, scenario.lidar.dropout);
    getOptional(lidar, "min_range", where, scenario.lidar.min_range);
    getOptional(lidar, "max_range", where, scenario.lidar.max_range);
  }
}

void parseSize(const YAML::Node& node, const std::string& where, double& length, double& width,
               double& height)
{
  const auto size = get<std::vector<double>>(node, "size", where);
  if (size.size() != 3 || size[0] <= 0.0 || size[1] <= 0.0 || size[2] <= 0.0)
  {
    throw std::runtime_error(where + ": size must be [length, width, height] > 0 [m]");
  }
  length = size[0];
  width = size[1];
  height = size[2];
}
}  // namespace

bool InsError::enabled() const
{
  return position_std != 0.0 || height_std != 0.0 || yaw_drift_rate != 0.0 || yaw_walk_std != 0.0 ||
         roll_std != 0.0 || pitch_std != 0.0;
}

void InsError::validate() const
{
  const std::pair<const char*, double> non_negative[] = {
      {"position_std", position_std}, {"position_correlation", position_correlation_s},
      {"height_std", height_std},     {"yaw_walk_std", yaw_walk_std},
      {"roll_std", roll_std},         {"pitch_std", pitch_std}};
  for (const auto& [name, value] : non_negative)
  {
    if (!(value >= 0.0))
    {
      throw std::invalid_argument(std::string("ins_error: ") + name + " must be >= 0, got " +
                                  std::to_string(value));
    }
  }
  if (!std::isfinite(yaw_drift_rate))
  {
    throw std::invalid_argument("ins_error: yaw_drift_rate must be finite");
  }
}

VehicleShape profileForType(const std::string& type)
{
  return type == "Car" ? VehicleShape::kCar : type == "Van" ? VehicleShape::kVan : VehicleShape::kBox;
}

int SyntheticScenario::frameCount() const
{
  return static_cast<int>(std::lround(duration_s * frame_rate_hz));
}

void SyntheticScenario::validate() const
{
  if (!(duration_s > 0.0))
  {
    throw std::invalid_argument("duration must be > 0 s");
  }
  if (!(frame_rate_hz > 0.0))
  {
    throw std::invalid_argument("frame_rate must be > 0 Hz");
  }
  if (frameCount() < 1)
  {
    throw std::invalid_argument("duration x frame_rate gives no frame");
  }
  if (!(oxts_delay_s >= 0.0 && oxts_delay_s < 0.5 / frame_rate_hz))
  {
    throw std::invalid_argument("oxts_delay must be in [0, half a frame), got " +
                                std::to_string(oxts_delay_s) + " s");
  }
  lidar.validate();
  try
  {
    ground.validate();
  }
  catch (const std::invalid_argument& e)
  {
    throw std::invalid_argument(std::string("ground: ") + e.what());
  }
  ins_error.validate();
  if (!(glass_transmission >= 0.0 && glass_transmission <= 1.0))
  {
    throw std::invalid_argument("glass_transmission must be in [0, 1], got " +
                                std::to_string(glass_transmission));
  }
  for (std::size_t i = 0; i < actors.size(); ++i)
  {
    if (!(actors[i].glass_transmission >= 0.0 && actors[i].glass_transmission <= 1.0))
    {
      throw std::invalid_argument("actors[" + std::to_string(i) + "]: glass_transmission must be in [0, 1]");
    }
  }
}

std::uint32_t parseColor(const std::string& text)
{
  const std::string hex = !text.empty() && text[0] == '#' ? text.substr(1) : text;
  if (hex.size() != 6 || hex.find_first_not_of("0123456789abcdefABCDEF") != std::string::npos)
  {
    throw std::invalid_argument("colour \"" + text + "\" is not #RRGGBB");
  }
  return static_cast<std::uint32_t>(std::stoul(hex, nullptr, 16));
}

SyntheticScenario loadScenario(const std::string& path)
{
  std::ifstream file(path);
  if (!file)
  {
    throw std::runtime_error("cannot read scenario " + path + ": bad file");
  }
  std::ostringstream text;
  text << file.rdbuf();  // an empty file gives an empty document (failbit on `text` only)
  return parseScenario(text.str(), path);
}

SyntheticScenario parseScenario(const std::string& yaml, const std::string& path)
{
  YAML::Node root;
  try
  {
    root = YAML::Load(yaml);
  }
  catch (const YAML::Exception& e)
  {
    throw std::runtime_error("cannot read scenario " + path + ": " + e.what());
  }
  SyntheticScenario scenario;
  getOptional(root, "seed", path, scenario.seed);
  getOptional(root, "duration", path, scenario.duration_s);
  getOptional(root, "frame_rate", path, scenario.frame_rate_hz);
  getOptional(root, "oxts_delay", path, scenario.oxts_delay_s);
  parseSettings(root, path, scenario);
  if (!root["ego"])
  {
    throw std::runtime_error(path + ": missing key 'ego'");
  }
  scenario.ego = parseMotion(root["ego"], path + ": ego");
  std::size_t index = 0;
  for (const auto& node : root["actors"])
  {
    const std::string where = path + ": actors[" + std::to_string(index++) + "]";
    Actor actor;
    actor.type = get<std::string>(node, "type", where);
    parseSize(node, where, actor.length, actor.width, actor.height);
    actor.trajectory = parseMotion(node, where);
    actor.color_rgb = colorOr(node, where, actor.color_rgb);
    actor.shape = node["shape"]               ? parseShape(node, "shape", where, true)
                  : scenario.vehicle_profiles ? profileForType(actor.type)
                                              : VehicleShape::kBox;
    actor.glass_transmission = scenario.glass_transmission;
    scenario.actors.push_back(actor);
  }
  index = 0;
  for (const auto& node : root["scenery"])
  {
    const std::string where = path + ": scenery[" + std::to_string(index++) + "]";
    SceneryBox box;
    box.box.pose = parsePose(node, where);
    parseSize(node, where, box.box.length, box.box.width, box.box.height);
    box.color_rgb = colorOr(node, where, box.color_rgb);
    scenario.scenery.push_back(box);
  }
  try
  {
    scenario.validate();
  }
  catch (const std::invalid_argument& e)
  {
    throw std::runtime_error(path + ": " + e.what());
  }
  return scenario;
}

}  // namespace grid_vision_fusion
