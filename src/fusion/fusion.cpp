#include "grid_vision_fusion/fusion/fusion.h"

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <sstream>
#include <stdexcept>

namespace grid_vision_fusion
{
namespace
{
constexpr double kMaxBandFraction = 10.0;
constexpr float kBoxTolerancePx = 1.F;

bool isFinite(float value)
{
  return std::isfinite(value);
}

bool validState(std::uint8_t state)
{
  return state == static_cast<std::uint8_t>(CellState::kStatic) ||
         state == static_cast<std::uint8_t>(CellState::kDynamic);
}

/// Whether point i can take part in the fusion at all.
bool validPoint(const ProjectedPointsView& points, std::size_t i)
{
  if (!isFinite(points.u[i]) || !isFinite(points.v[i]) || !isFinite(points.x[i]) || !isFinite(points.y[i]) ||
      !validState(points.state[i]))
  {
    return false;
  }
  const bool dynamic = points.state[i] == static_cast<std::uint8_t>(CellState::kDynamic);
  return !dynamic || (isFinite(points.vx[i]) && isFinite(points.vy[i]));
}

/// Detection indices ordered for exclusive assignment: nearest first (largest y_max), then
/// higher score, then earlier detection.
std::vector<std::size_t> depthOrder(const std::vector<Detection>& detections)
{
  std::vector<std::size_t> order(detections.size());
  std::iota(order.begin(), order.end(), 0U);
  std::stable_sort(order.begin(), order.end(),
                   [&](std::size_t a, std::size_t b)
                   {
                     const auto& da = detections[a];
                     const auto& db = detections[b];
                     if (da.box.y_max != db.box.y_max)
                     {
                       return da.box.y_max > db.box.y_max;
                     }
                     return da.score > db.score;
                   });
  return order;
}

/// The object of a box whose band holds no point: motion unknown, no position yet.
FusedObject unsupportedObject(std::size_t detection_index)
{
  FusedObject object;
  object.detection_index = detection_index;
  object.support = ObjectSupport::kBox;
  object.median_x = object.median_y = std::numeric_limits<double>::quiet_NaN();
  return object;
}

FusedObject pointwiseFeatures(std::size_t detection_index, const BoundingBox& box,
                              const std::vector<std::size_t>& members, const ProjectedPointsView& points,
                              const FusionConfig& config, const std::vector<Eigen::Vector2d>& expected)
{
  FusedObject object;
  object.detection_index = detection_index;
  std::vector<double> xs, ys, vxs, vys;
  xs.reserve(members.size());
  ys.reserve(members.size());
  object.members.reserve(members.size());
  for (std::size_t i : members)
  {
    xs.push_back(points.x[i]);
    ys.push_back(points.y[i]);
    object.members.push_back(static_cast<std::uint32_t>(i));
  }
  object.median_x = median(xs);
  object.median_y = median(ys);
  object.cluster = objectCluster(points, object.members, box, config.centre.cluster_distance, expected);
  object.grid = gridEvidence(points, object.cluster);
  for (std::uint32_t i : config.motion_vote == MotionVote::kCluster ? object.cluster : object.members)
  {
    if (points.state[i] == static_cast<std::uint8_t>(CellState::kDynamic))
    {
      ++object.dynamic_points;
      vxs.push_back(points.vx[i]);
      vys.push_back(points.vy[i]);
    }
    else
    {
      ++object.static_points;
    }
  }
  object.vote = decideMotion(object.static_points, object.dynamic_points, config);
  const double votes = static_cast<double>(object.static_points) + object.dynamic_points;
  object.dynamic_share = votes > 0.0 ? object.dynamic_points / votes : 0.5;
  if (object.vote == Motion::kDynamic)
  {
    object.vote_vx = median(vxs);
    object.vote_vy = median(vys);
  }
  return object;
}
}  // namespace

TieRule tieRuleFromString(const std::string& name)
{
  if (name == "static")
  {
    return TieRule::kStatic;
  }
  if (name == "dynamic")
  {
    return TieRule::kDynamic;
  }
  if (name == "unknown")
  {
    return TieRule::kUnknown;
  }
  throw std::invalid_argument("tie_rule must be \"static\", \"dynamic\" or \"unknown\", got \"" + name +
                              "\"");
}

PositionSource positionSourceFromString(const std::string& name)
{
  if (name == "centre")
  {
    return PositionSource::kCentre;
  }
  if (name == "median")
  {
    return PositionSource::kMedian;
  }
  throw std::invalid_argument("position must be \"centre\" or \"median\", got \"" + name + "\"");
}

MotionVote motionVoteFromString(const std::string& name)
{
  if (name == "region")
  {
    return MotionVote::kRegion;
  }
  if (name == "cluster")
  {
    return MotionVote::kCluster;
  }
  throw std::invalid_argument("motion_vote must be \"region\" or \"cluster\", got \"" + name + "\"");
}

std::string toString(MotionVote vote)
{
  return vote == MotionVote::kRegion ? "region" : "cluster";
}

std::string toString(PositionSource source)
{
  return source == PositionSource::kCentre ? "centre" : "median";
}

std::string toString(TieRule rule)
{
  switch (rule)
  {
    case TieRule::kStatic:
      return "static";
    case TieRule::kDynamic:
      return "dynamic";
    case TieRule::kUnknown:
      break;
  }
  return "unknown";
}

void FusionConfig::validate() const
{
  auto check_fraction = [](const char* name, double value)
  {
    if (!std::isfinite(value) || value < 0.0 || value > kMaxBandFraction)
    {
      std::ostringstream msg;
      msg << name << " must be a fraction of the box height in [0, " << kMaxBandFraction << "], got "
          << value;
      throw std::invalid_argument(msg.str());
    }
  };
  check_fraction("band_above", band_above);
  check_fraction("band_below", band_below);
  if (min_points < 1)
  {
    throw std::invalid_argument("min_points must be >= 1, got " + std::to_string(min_points));
  }
  centre.validate();
}

void ProjectedPoints::add(float pu, float pv, float px, float py, float pvx, float pvy, CellState s)
{
  u.push_back(pu);
  v.push_back(pv);
  x.push_back(px);
  y.push_back(py);
  vx.push_back(pvx);
  vy.push_back(pvy);
  state.push_back(static_cast<std::uint8_t>(s));
}

ProjectedPointsView ProjectedPoints::view() const
{
  return pointsViewOf(*this);
}

FusionRegion FusionRegion::fromBox(const BoundingBox& box, const FusionConfig& config)
{
  const double h = box.height();
  FusionRegion region;
  region.u_min = box.x_min;
  region.u_max = box.x_max;
  region.v_min = static_cast<float>(box.y_max - config.band_above * h);
  region.v_max = static_cast<float>(box.y_max + config.band_below * h);
  return region;
}

Eigen::Vector2d FusedObject::position(PositionSource source) const
{
  return source == PositionSource::kCentre ? Eigen::Vector2d(centre_x, centre_y)
                                           : Eigen::Vector2d(median_x, median_y);
}

double ReportedObject::speed() const
{
  return std::hypot(vx, vy);
}

GridMotionEvidence gridEvidence(const ProjectedPointsView& points, const std::vector<std::uint32_t>& cells)
{
  GridMotionEvidence evidence;
  if (cells.empty())
  {
    return evidence;
  }
  double share_sum = 0.0;
  double weight_sum = 0.0;  // the shares of the cells with a finite velocity
  Eigen::Vector2d velocity_sum = Eigen::Vector2d::Zero();
  Eigen::Vector2d square_sum = Eigen::Vector2d::Zero();
  const bool variances = points.v_var_x != nullptr && points.v_var_y != nullptr;
  for (std::uint32_t i : cells)
  {
    double share = points.state[i] == static_cast<std::uint8_t>(CellState::kDynamic) ? 1.0 : 0.0;
    if (points.p_static != nullptr && points.p_dynamic != nullptr)
    {
      const double occupied = static_cast<double>(points.p_static[i]) + points.p_dynamic[i];
      share = occupied > 0.0 ? points.p_dynamic[i] / occupied : 0.5;
    }
    share_sum += share;
    const Eigen::Vector2d v(points.vx[i], points.vy[i]);
    if (variances && v.allFinite())
    {
      weight_sum += share;
      velocity_sum += share * v;
      square_sum += share * (v.cwiseProduct(v) + Eigen::Vector2d(points.v_var_x[i], points.v_var_y[i]));
    }
  }
  evidence.dynamic_share = share_sum / static_cast<double>(cells.size());
  if (weight_sum > 0.0)
  {
    evidence.velocity = velocity_sum / weight_sum;
    evidence.velocity_variance =
        (square_sum / weight_sum - evidence.velocity.cwiseProduct(evidence.velocity)).cwiseMax(0.0);
    evidence.has_velocity = evidence.velocity.allFinite() && evidence.velocity_variance.allFinite();
  }
  return evidence;
}

double median(std::vector<double>& values)
{
  if (values.empty())
  {
    throw std::invalid_argument("median of an empty set");
  }
  const std::size_t mid = values.size() / 2;
  std::nth_element(values.begin(), values.begin() + static_cast<std::ptrdiff_t>(mid), values.end());
  const double upper = values[mid];
  if (values.size() % 2 == 1)
  {
    return upper;
  }
  const double lower = *std::max_element(values.begin(), values.begin() + static_cast<std::ptrdiff_t>(mid));
  return 0.5 * (lower + upper);
}

Motion decideMotion(std::uint32_t static_points, std::uint32_t dynamic_points, const FusionConfig& config)
{
  Motion motion = Motion::kUnknown;
  if (static_points > dynamic_points)
  {
    motion = Motion::kStatic;
  }
  else if (dynamic_points > static_points)
  {
    motion = Motion::kDynamic;
  }
  else if (static_points == 0)
  {
    return Motion::kUnknown;
  }
  else
  {
    motion = config.tie_rule == TieRule::kStatic    ? Motion::kStatic
             : config.tie_rule == TieRule::kDynamic ? Motion::kDynamic
                                                    : Motion::kUnknown;
  }
  const std::uint32_t winner = std::max(static_points, dynamic_points);
  if (winner < static_cast<std::uint32_t>(config.min_points))
  {
    return Motion::kUnknown;
  }
  return motion;
}

FusionResult fuse(const std::vector<Detection>& detections, const ProjectedPointsView& points,
                  const FusionConfig& config, const std::vector<std::vector<Eigen::Vector2d>>& expected)
{
  FusionResult result;
  std::vector<FusionRegion> regions;
  regions.reserve(detections.size());
  for (const auto& detection : detections)
  {
    regions.push_back(FusionRegion::fromBox(detection.box, config));
  }

  std::vector<std::vector<std::size_t>> members(detections.size());
  const std::vector<std::size_t> order =
      config.exclusive_assignment ? depthOrder(detections) : std::vector<std::size_t>{};
  for (std::size_t i = 0; i < points.size; ++i)
  {
    if (!validPoint(points, i))
    {
      ++result.invalid_points;
      continue;
    }
    if (config.exclusive_assignment)
    {
      for (std::size_t d : order)
      {
        if (regions[d].contains(points.u[i], points.v[i]))
        {
          members[d].push_back(i);
          break;
        }
      }
      continue;
    }
    for (std::size_t d = 0; d < regions.size(); ++d)
    {
      if (regions[d].contains(points.u[i], points.v[i]))
      {
        members[d].push_back(i);
      }
    }
  }

  for (std::size_t d = 0; d < detections.size(); ++d)
  {
    if (members[d].empty())
    {
      result.objects.push_back(unsupportedObject(d));
    }
    else
    {
      static const std::vector<Eigen::Vector2d> kNone;
      result.objects.push_back(pointwiseFeatures(d, detections[d].box, members[d], points, config,
                                                 d < expected.size() ? expected[d] : kNone));
    }
  }
  return result;
}

bool ImageGround::valid() const
{
  return grid_to_image.allFinite() && std::isfinite(ground_z) &&
         std::abs(grid_to_image.leftCols<3>().determinant()) > 1e-12;
}

Eigen::Vector2d ImageGround::cameraPosition() const
{
  const Eigen::Matrix3d a = grid_to_image.leftCols<3>();
  return (-a.inverse() * grid_to_image.col(3)).head<2>();
}

Eigen::Vector2d ImageGround::groundPoint(double u, double v, double max_range) const
{
  const Eigen::Matrix3d a = grid_to_image.leftCols<3>();
  const Eigen::Vector3d centre = -a.inverse() * grid_to_image.col(3);
  Eigen::Vector3d ray = a.inverse() * Eigen::Vector3d(u, v, 1.0);
  if (a.row(2).dot(ray) < 0.0)
  {
    ray = -ray;  // the line of sight in front of the camera
  }
  const Eigen::Vector2d level = ray.head<2>();
  if (ray.z() < 0.0)
  {
    const Eigen::Vector3d hit = centre + (ground_z - centre.z()) / ray.z() * ray;
    if ((hit - centre).head<2>().norm() <= max_range)
    {
      return hit.head<2>();
    }
  }
  return level.norm() > 0.0 ? Eigen::Vector2d(centre.head<2>() + max_range * level.normalized())
                            : Eigen::Vector2d(centre.head<2>());
}

void placeOnGround(FusionResult& result, const std::vector<Detection>& detections, const ImageGround& ground,
                   const std::map<std::string, Footprint>& footprints)
{
  if (!ground.valid())
  {
    return;
  }
  const Eigen::Vector2d camera = ground.cameraPosition();
  for (FusedObject& object : result.objects)
  {
    if (object.support != ObjectSupport::kBox)
    {
      continue;
    }
    const Detection& detection = detections.at(object.detection_index);
    const BoundingBox& box = detection.box;
    const Eigen::Vector2d foot =
        ground.groundPoint(0.5 * (box.x_min + box.x_max), box.y_max, kMaxBoxGroundRange);
    const auto footprint = footprints.find(detection.label);
    const double depth =
        footprint == footprints.end() ? 0.0 : 0.25 * (footprint->second.length + footprint->second.width);
    const Eigen::Vector2d sight = foot - camera;
    const Eigen::Vector2d centre =
        sight.norm() > 0.0 ? Eigen::Vector2d(foot + depth * sight.normalized()) : foot;
    object.centre_x = object.median_x = centre.x();
    object.centre_y = object.median_y = centre.y();
  }
}

void reportPerFrame(FusionResult& result, const std::vector<Detection>& detections, PositionSource position)
{
  result.reports.clear();
  result.reports.reserve(result.objects.size());
  for (std::size_t i = 0; i < result.objects.size(); ++i)
  {
    const FusedObject& object = result.objects[i];
    const Detection& detection = detections.at(object.detection_index);
    ReportedObject report;
    report.id = static_cast<std::uint32_t>(object.detection_index);
    report.label = detection.label;
    report.class_id = detection.class_id;
    report.support = object.support;
    report.motion = object.vote;
    report.p_dynamic = object.dynamic_share;
    // An object without cells has its box's place on the ground as centre and median alike.
    const Eigen::Vector2d at = object.position(position);
    report.x = at.x();
    report.y = at.y();
    report.vx = object.vote_vx;
    report.vy = object.vote_vy;
    report.heading = object.vote == Motion::kDynamic ? std::atan2(object.vote_vy, object.vote_vx) : 0.0;
    result.reports.push_back(std::move(report));
  }
  result.tracked = false;
}

std::string checkFusionInputs(const std::vector<Detection>& detections, std::uint32_t detections_width,
                              std::uint32_t detections_height, std::uint32_t points_width,
                              std::uint32_t points_height)
{
  std::ostringstream msg;
  if (detections_width != points_width || detections_height != points_height)
  {
    msg << "image size mismatch: detections are for " << detections_width << "x" << detections_height
        << ", projected grid for " << points_width << "x" << points_height;
    return msg.str();
  }
  const float width = static_cast<float>(detections_width);
  const float height = static_cast<float>(detections_height);
  for (std::size_t i = 0; i < detections.size(); ++i)
  {
    const BoundingBox& b = detections[i].box;
    msg << "detection " << i << " (\"" << detections[i].label << "\") box [" << b.x_min << ", " << b.y_min
        << ", " << b.x_max << ", " << b.y_max << "] ";
    if (!isFinite(b.x_min) || !isFinite(b.y_min) || !isFinite(b.x_max) || !isFinite(b.y_max))
    {
      msg << "has a non-finite coordinate";
      return msg.str();
    }
    if (b.x_min > b.x_max || b.y_min > b.y_max)
    {
      msg << "has x_min > x_max or y_min > y_max";
      return msg.str();
    }
    if (b.x_min < -kBoxTolerancePx || b.y_min < -kBoxTolerancePx || b.x_max > width + kBoxTolerancePx ||
        b.y_max > height + kBoxTolerancePx)
    {
      msg << "lies outside the " << detections_width << "x" << detections_height << " image";
      return msg.str();
    }
    msg.str("");
  }
  return {};
}

void estimateCentres(FusionResult& result, const std::vector<Detection>& detections,
                     const ProjectedPointsView& points, double camera_x, double camera_y,
                     const CentreConfig& config)
{
  for (FusedObject& object : result.objects)
  {
    if (object.detection_index >= detections.size())
    {
      throw std::invalid_argument("estimateCentres: detection index " +
                                  std::to_string(object.detection_index) + " outside the " +
                                  std::to_string(detections.size()) + " detections");
    }
    if (object.members.empty())
    {
      continue;  // no cell: placeOnGround() places it
    }
    const Detection& detection = detections[object.detection_index];
    const auto footprint = config.footprints.find(detection.label);
    const Footprint* size = footprint == config.footprints.end() ? nullptr : &footprint->second;
    // fuse() has found the object's cluster already (at the same cluster distance).
    const CentreEstimate centre =
        object.cluster.empty()
            ? estimateCentre(points, object.members, detection.box, camera_x, camera_y, size, config)
            : centreOfCluster(points, object.cluster, camera_x, camera_y, size, config.max_scans_since_hit);
    object.centre_x = centre.x;
    object.centre_y = centre.y;
    object.length = centre.length;
  }
}

}  // namespace grid_vision_fusion
