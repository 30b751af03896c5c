#include "grid_vision_fusion/core/synthetic_world.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace grid_vision_fusion
{
namespace
{
constexpr double kDegToRad = M_PI / 180.0;
constexpr double kStandingEps = 1e-9;

struct Sphere
{
  Eigen::Vector3d centre;
  double radius;
};

Sphere boundingSphere(const GroundBox& box)
{
  return {Eigen::Vector3d(box.pose.x, box.pose.y, box.height / 2.0),
          0.5 * std::sqrt(box.length * box.length + box.width * box.width + box.height * box.height)};
}

/// Whether the ray may hit the sphere within (min_range, max_range].
bool mayHit(const Eigen::Vector3d& centre, double radius, const Eigen::Vector3d& origin,
            const Eigen::Vector3d& direction, double min_range, double max_range)
{
  const Eigen::Vector3d oc = centre - origin;
  const double along = oc.dot(direction);
  if (along + radius < min_range || along - radius > max_range)
  {
    return false;
  }
  return oc.squaredNorm() - along * along <= radius * radius;
}
}  // namespace

Trajectory Trajectory::waypoints(const std::vector<Eigen::Vector3d>& t_x_y, double initial_yaw)
{
  if (t_x_y.empty())
  {
    throw std::invalid_argument("a waypoint trajectory needs at least one waypoint");
  }
  for (std::size_t i = 1; i < t_x_y.size(); ++i)
  {
    if (!(t_x_y[i].x() > t_x_y[i - 1].x()))
    {
      throw std::invalid_argument("waypoint times must increase strictly (waypoint " + std::to_string(i) +
                                  ")");
    }
  }
  Trajectory trajectory;
  trajectory.kind_ = Kind::kWaypoints;
  trajectory.waypoints_ = t_x_y;
  // Yaw of every segment: its direction when it moves, else the yaw of the last moving segment
  // before it (or, for leading standing segments, of the first moving one).
  const std::size_t segments = t_x_y.size() > 1 ? t_x_y.size() - 1 : 0;
  std::vector<double> yaw(segments, std::nan(""));
  for (std::size_t i = 0; i < segments; ++i)
  {
    const Eigen::Vector2d step = t_x_y[i + 1].tail<2>() - t_x_y[i].tail<2>();
    if (step.norm() > kStandingEps)
    {
      yaw[i] = std::atan2(step.y(), step.x());
    }
  }
  double held = initial_yaw;
  for (double y : yaw)
  {
    if (!std::isnan(y))
    {
      held = y;
      break;
    }
  }
  for (double& y : yaw)
  {
    if (std::isnan(y))
    {
      y = held;
    }
    held = y;
  }
  trajectory.segment_yaw_ = yaw;
  trajectory.start_.yaw = yaw.empty() ? initial_yaw : yaw.front();
  return trajectory;
}

Trajectory Trajectory::constantTurn(const Pose2D& start, double speed, double yaw_rate)
{
  Trajectory trajectory;
  trajectory.kind_ = Kind::kConstantTurn;
  trajectory.start_ = start;
  trajectory.speed_ = speed;
  trajectory.yaw_rate_ = yaw_rate;
  return trajectory;
}

Trajectory Trajectory::posed(const std::vector<double>& times, const std::vector<Pose2D>& poses)
{
  if (times.size() != poses.size())
  {
    throw std::invalid_argument("posed trajectory: " + std::to_string(times.size()) + " times for " +
                                std::to_string(poses.size()) + " poses");
  }
  std::vector<Eigen::Vector3d> t_x_y;
  for (std::size_t i = 0; i < poses.size(); ++i)
  {
    t_x_y.emplace_back(times[i], poses[i].x, poses[i].y);
  }
  Trajectory trajectory = waypoints(t_x_y, poses.empty() ? 0.0 : poses.front().yaw);
  for (const Pose2D& pose : poses)
  {
    trajectory.waypoint_yaw_.push_back(pose.yaw);
  }
  trajectory.start_.yaw = poses.front().yaw;
  return trajectory;
}

Trajectory Trajectory::parked(const Pose2D& pose)
{
  return waypoints({Eigen::Vector3d(0.0, pose.x, pose.y)}, pose.yaw);
}

Pose2D Trajectory::poseAt(double t) const
{
  if (kind_ == Kind::kConstantTurn)
  {
    Pose2D pose;
    pose.yaw = start_.yaw + yaw_rate_ * t;
    if (std::abs(yaw_rate_) < 1e-12)
    {
      pose.x = start_.x + speed_ * t * std::cos(start_.yaw);
      pose.y = start_.y + speed_ * t * std::sin(start_.yaw);
    }
    else
    {
      const double r = speed_ / yaw_rate_;
      pose.x = start_.x + r * (std::sin(pose.yaw) - std::sin(start_.yaw));
      pose.y = start_.y - r * (std::cos(pose.yaw) - std::cos(start_.yaw));
    }
    return pose;
  }
  const auto& w = waypoints_;
  if (t <= w.front().x() || w.size() == 1)
  {
    return {w.front().y(), w.front().z(), start_.yaw};
  }
  if (t >= w.back().x())
  {
    return {w.back().y(), w.back().z(), waypoint_yaw_.empty() ? segment_yaw_.back() : waypoint_yaw_.back()};
  }
  const auto next = std::upper_bound(w.begin(), w.end(), t,
                                     [](double time, const Eigen::Vector3d& p) { return time < p.x(); });
  const std::size_t i = static_cast<std::size_t>(next - w.begin()) - 1;
  const double s = (t - w[i].x()) / (w[i + 1].x() - w[i].x());
  const Eigen::Vector2d p = (1.0 - s) * w[i].tail<2>() + s * w[i + 1].tail<2>();
  if (waypoint_yaw_.empty())
  {
    return {p.x(), p.y(), segment_yaw_[i]};
  }
  const double turn = std::remainder(waypoint_yaw_[i + 1] - waypoint_yaw_[i], 2.0 * M_PI);
  return {p.x(), p.y(), std::remainder(waypoint_yaw_[i] + s * turn, 2.0 * M_PI)};
}

Eigen::Vector2d Trajectory::velocityAt(double t) const
{
  if (kind_ == Kind::kConstantTurn)
  {
    const double yaw = start_.yaw + yaw_rate_ * t;
    return speed_ * Eigen::Vector2d(std::cos(yaw), std::sin(yaw));
  }
  const auto& w = waypoints_;
  if (w.size() == 1 || t < w.front().x() || t >= w.back().x())
  {
    return Eigen::Vector2d::Zero();
  }
  const auto next = std::upper_bound(w.begin(), w.end(), t,
                                     [](double time, const Eigen::Vector3d& p) { return time < p.x(); });
  const std::size_t i = static_cast<std::size_t>(next - w.begin()) - 1;
  return (w[i + 1].tail<2>() - w[i].tail<2>()) / (w[i + 1].x() - w[i].x());
}

std::vector<Eigen::Vector3d> GroundBox::corners() const
{
  const double c = std::cos(pose.yaw);
  const double s = std::sin(pose.yaw);
  const double hl = length / 2.0;
  const double hw = width / 2.0;
  const double local[4][2] = {{hl, hw}, {-hl, hw}, {-hl, -hw}, {hl, -hw}};
  std::vector<Eigen::Vector3d> out;
  for (double z : {0.0, height})
  {
    for (const auto& xy : local)
    {
      out.emplace_back(pose.x + c * xy[0] - s * xy[1], pose.y + s * xy[0] + c * xy[1], z);
    }
  }
  return out;
}

GroundBox Actor::boxAt(double t) const
{
  GroundBox box;
  box.pose = trajectory.poseAt(t);
  box.length = length;
  box.width = width;
  box.height = height;
  return box;
}

RayHit intersectBox(const GroundBox& box, const Eigen::Vector3d& origin, const Eigen::Vector3d& direction,
                    double min_range)
{
  const double c = std::cos(box.pose.yaw);
  const double s = std::sin(box.pose.yaw);
  const Eigen::Vector3d rel = origin - Eigen::Vector3d(box.pose.x, box.pose.y, 0.0);
  // Into the box frame: rotate by −yaw.
  const Eigen::Vector3d o(c * rel.x() + s * rel.y(), -s * rel.x() + c * rel.y(), rel.z());
  const Eigen::Vector3d d(c * direction.x() + s * direction.y(), -s * direction.x() + c * direction.y(),
                          direction.z());
  const double lo[3] = {-box.length / 2.0, -box.width / 2.0, 0.0};
  const double hi[3] = {box.length / 2.0, box.width / 2.0, box.height};
  double t_enter = -std::numeric_limits<double>::infinity();
  double t_exit = std::numeric_limits<double>::infinity();
  int enter_axis = -1;
  double enter_sign = 0.0;
  for (int axis = 0; axis < 3; ++axis)
  {
    if (std::abs(d[axis]) < 1e-12)
    {
      if (o[axis] < lo[axis] || o[axis] > hi[axis])
      {
        return {};
      }
      continue;
    }
    double t0 = (lo[axis] - o[axis]) / d[axis];
    double t1 = (hi[axis] - o[axis]) / d[axis];
    double sign = -1.0;  // entering through the low face: its normal points to −axis
    if (t0 > t1)
    {
      std::swap(t0, t1);
      sign = 1.0;
    }
    if (t0 > t_enter)
    {
      t_enter = t0;
      enter_axis = axis;
      enter_sign = sign;
    }
    t_exit = std::min(t_exit, t1);
  }
  if (t_enter > t_exit || t_enter <= min_range || enter_axis < 0)
  {
    return {};
  }
  RayHit hit;
  hit.range = t_enter;
  hit.object = 0;
  Eigen::Vector3d local_normal = Eigen::Vector3d::Zero();
  local_normal[enter_axis] = enter_sign;
  hit.normal = Eigen::Vector3d(c * local_normal.x() - s * local_normal.y(),
                               s * local_normal.x() + c * local_normal.y(), local_normal.z());
  return hit;
}

SceneSnapshot::SceneSnapshot(const std::vector<Actor>& actors, const std::vector<SceneryBox>& scenery,
                             double t)
{
  for (const auto& actor : actors)
  {
    actor_boxes_.push_back(actor.boxAt(t));
    actor_active_.push_back(actor.activeAt(t));
    bound_radius_.push_back(boundingSphere(actor_boxes_.back()).radius);
  }
  for (const auto& item : scenery)
  {
    scenery_boxes_.push_back(item.box);
    bound_radius_.push_back(boundingSphere(item.box).radius);
  }
  culled_.assign(bound_radius_.size(), false);
}

void SceneSnapshot::cullBeyond(const Eigen::Vector2d& centre, double radius)
{
  const std::size_t actors = actor_boxes_.size();
  for (std::size_t i = 0; i < culled_.size(); ++i)
  {
    const GroundBox& box = i < actors ? actor_boxes_[i] : scenery_boxes_[i - actors];
    culled_[i] = (Eigen::Vector2d(box.pose.x, box.pose.y) - centre).norm() - bound_radius_[i] > radius;
  }
}

RayHit SceneSnapshot::cast(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction, double min_range,
                           double max_range) const
{
  RayHit best;
  if (direction.z() < -1e-12)
  {
    const double t = -origin.z() / direction.z();
    if (t > min_range && t <= max_range)
    {
      best.range = t;
      best.object = RayHit::kGround;
      best.normal = Eigen::Vector3d::UnitZ();
    }
  }
  const std::size_t actors = actor_boxes_.size();
  for (std::size_t i = 0; i < actors + scenery_boxes_.size(); ++i)
  {
    if (culled_[i] || (i < actors && !actor_active_[i]))
    {
      continue;
    }
    const GroundBox& box = i < actors ? actor_boxes_[i] : scenery_boxes_[i - actors];
    const double limit = std::min(max_range, best.range);
    if (!mayHit(boundingSphere(box).centre, bound_radius_[i], origin, direction, min_range, limit))
    {
      continue;
    }
    RayHit hit = intersectBox(box, origin, direction, min_range);
    if (hit.range < best.range && hit.range <= max_range)
    {
      hit.object = i < actors ? static_cast<int>(i) : RayHit::kSceneryBase + static_cast<int>(i - actors);
      best = hit;
    }
  }
  return best;
}

void SceneSnapshot::actorsAlong(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction,
                                double min_range, double max_range, std::vector<int>& actors) const
{
  for (std::size_t i = 0; i < actor_boxes_.size(); ++i)
  {
    if (actor_active_[i] && !culled_[i] &&
        mayHit(boundingSphere(actor_boxes_[i]).centre, bound_radius_[i], origin, direction, min_range,
               max_range) &&
        intersectBox(actor_boxes_[i], origin, direction, min_range).range <= max_range)
    {
      actors.push_back(static_cast<int>(i));
    }
  }
}

std::vector<double> LidarConfig::hdl64Elevations()
{
  std::vector<double> elevations;
  for (int i = 0; i < 32; ++i)
  {
    elevations.push_back((2.0 - i / 3.0) * kDegToRad);
  }
  for (int i = 0; i < 32; ++i)
  {
    elevations.push_back((-8.83 - i * 0.5) * kDegToRad);
  }
  return elevations;
}

void LidarConfig::validate() const
{
  if (azimuth_steps < 1)
  {
    throw std::invalid_argument("azimuth_steps must be >= 1");
  }
  if (!(min_range >= 0.0 && max_range > min_range))
  {
    throw std::invalid_argument("need 0 <= min_range < max_range");
  }
  if (!(range_noise_std >= 0.0))
  {
    throw std::invalid_argument("range_noise_std must be >= 0");
  }
  if (!(dropout >= 0.0 && dropout < 1.0))
  {
    throw std::invalid_argument("dropout must be in [0, 1)");
  }
}

std::vector<LidarPoint> simulateLidarScan(const SceneSnapshot& scene, const Eigen::Isometry3d& sensor_pose,
                                          const LidarConfig& config, std::mt19937& rng)
{
  config.validate();
  const std::vector<double> elevations =
      config.elevations.empty() ? LidarConfig::hdl64Elevations() : config.elevations;
  std::normal_distribution<double> noise(0.0, config.range_noise_std);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  const Eigen::Matrix3d rotation = sensor_pose.linear();
  const Eigen::Vector3d origin = sensor_pose.translation();
  std::vector<LidarPoint> points;
  points.reserve(static_cast<std::size_t>(config.azimuth_steps) * elevations.size());
  for (int a = 0; a < config.azimuth_steps; ++a)
  {
    const double azimuth = M_PI - 2.0 * M_PI * a / config.azimuth_steps;  // from the back, clockwise
    const double ca = std::cos(azimuth);
    const double sa = std::sin(azimuth);
    for (double elevation : elevations)
    {
      const Eigen::Vector3d local(std::cos(elevation) * ca, std::cos(elevation) * sa, std::sin(elevation));
      const Eigen::Vector3d direction = rotation * local;
      const RayHit hit = scene.cast(origin, direction, config.min_range, config.max_range);
      // Draw both random numbers for every ray so that the stream does not depend on the hits.
      const double drop = uniform(rng);
      const double range_noise = config.range_noise_std > 0.0 ? noise(rng) : 0.0;
      if (!hit.hit() || drop < config.dropout)
      {
        continue;
      }
      const double range = std::max(config.min_range, hit.range + range_noise);
      const double incidence = std::abs(hit.normal.dot(direction));
      const double intensity = std::clamp((0.15 + 0.85 * incidence) * std::exp(-range / 80.0), 0.0, 1.0);
      points.push_back({static_cast<float>(local.x() * range), static_cast<float>(local.y() * range),
                        static_cast<float>(local.z() * range), static_cast<float>(intensity)});
    }
  }
  return points;
}

}  // namespace grid_vision_fusion
