#include "grid_vision_fusion/fusion/tracker.h"

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>

#include "grid_vision_fusion/fusion/assignment.h"

namespace grid_vision_fusion
{
namespace
{
void requirePositive(const char* name, double value)
{
  if (!std::isfinite(value) || value <= 0.0)
  {
    std::ostringstream msg;
    msg << name << " must be a finite value > 0, got " << value;
    throw std::invalid_argument(msg.str());
  }
}

/// Cells of the object's cluster that each image of a young track needs for its early
/// displacement to count: the centre estimated from fewer (a corner of a car coming into view)
/// moves as more of the object shows, not with the object.
constexpr std::uint32_t kEarlyMinCells = 3;

/// a and b point within 45° of each other (false when either is zero).
bool within45Degrees(const Eigen::Vector2d& a, const Eigen::Vector2d& b)
{
  constexpr double kCos45 = 0.7071067811865476;
  return a.dot(b) > kCos45 * a.norm() * b.norm();
}

void requireNonNegative(const char* name, double value)
{
  if (!std::isfinite(value) || value < 0.0)
  {
    std::ostringstream msg;
    msg << name << " must be a finite value >= 0, got " << value;
    throw std::invalid_argument(msg.str());
  }
}
}  // namespace

void TrackerConfig::validate() const
{
  if (min_hits < 1)
  {
    throw std::invalid_argument("track_min_hits must be >= 1, got " + std::to_string(min_hits));
  }
  if (max_misses < 0)
  {
    throw std::invalid_argument("track_max_misses must be >= 0, got " + std::to_string(max_misses));
  }
  requirePositive("track_gate_sigma", gate_sigma);
  if (!(min_iou > 0.0 && min_iou <= 1.0))
  {
    throw std::invalid_argument("track_min_iou must be in (0, 1], got " + std::to_string(min_iou));
  }
  if (!std::isfinite(iou_weight) || iou_weight < 0.0)
  {
    throw std::invalid_argument("track_iou_weight must be a finite value >= 0, got " +
                                std::to_string(iou_weight));
  }
  requirePositive("track_acceleration_sigma", acceleration_sigma);
  requirePositive("track_position_sigma", position_sigma);
  requirePositive("track_velocity_sigma", velocity_sigma);
  requirePositive("track_initial_speed_sigma", initial_speed_sigma);
  requirePositive("track_max_gap", max_gap);
  requirePositive("motion_evidence_limit", motion_evidence_limit);
  if (!(motion_switch_evidence > 0.0 && motion_switch_evidence <= motion_evidence_limit))
  {
    throw std::invalid_argument("motion_switch_evidence must be in (0, motion_evidence_limit], got " +
                                std::to_string(motion_switch_evidence));
  }
  requireNonNegative("track_robust_sigma", robust_sigma);
  requireNonNegative("motion_speed_evidence", speed_evidence);
  requirePositive("motion_speed_threshold", motion_speed_threshold);
  requirePositive("motion_speed_window", motion_speed_window);
  requireNonNegative("motion_min_dwell", motion_min_dwell);
  requireNonNegative("motion_grid_velocity_evidence", grid_velocity_evidence);
  requireNonNegative("motion_early_displacement", early_displacement);
  requireNonNegative("motion_step_tolerance", step_tolerance);
  if (!(still_window >= 0.0 && still_window <= motion_speed_window))
  {
    throw std::invalid_argument("motion_still_window must be in [0, motion_speed_window], got " +
                                std::to_string(still_window));
  }
  if (!(still_short_window >= 0.0 && still_short_window <= motion_speed_window))
  {
    throw std::invalid_argument("motion_still_short_window must be in [0, motion_speed_window], got " +
                                std::to_string(still_short_window));
  }
  if (!(grid_velocity_agreement > 0.0 && grid_velocity_agreement <= 1.0))
  {
    throw std::invalid_argument("motion_grid_velocity_agreement must be in (0, 1], got " +
                                std::to_string(grid_velocity_agreement));
  }
  if (grid_velocity_min_cells < 1)
  {
    throw std::invalid_argument("motion_grid_velocity_min_cells must be >= 1, got " +
                                std::to_string(grid_velocity_min_cells));
  }
}

double boxOverlap(const BoundingBox& a, const BoundingBox& b)
{
  const double iw = std::min(a.x_max, b.x_max) - std::max(a.x_min, b.x_min);
  const double ih = std::min(a.y_max, b.y_max) - std::max(a.y_min, b.y_min);
  if (!(iw > 0.0) || !(ih > 0.0))
  {
    return 0.0;
  }
  const double area_a = (static_cast<double>(a.x_max) - a.x_min) * (static_cast<double>(a.y_max) - a.y_min);
  const double area_b = (static_cast<double>(b.x_max) - b.x_min) * (static_cast<double>(b.y_max) - b.y_min);
  const double union_area = area_a + area_b - iw * ih;
  return union_area > 0.0 ? iw * ih / union_area : 0.0;
}

Tracker::Tracker(const TrackerConfig& config) : config_(config)
{
  config_.validate();
}

void Tracker::setConfig(const TrackerConfig& config)
{
  config.validate();
  config_ = config;
}

void Tracker::reset()
{
  tracks_.clear();
  has_stamp_ = false;
}

void Tracker::predict(Track& track, double dt) const
{
  if (dt <= 0.0)
  {
    return;
  }
  Eigen::Matrix4d f = Eigen::Matrix4d::Identity();
  f(0, 2) = dt;
  f(1, 3) = dt;
  const double q = config_.acceleration_sigma * config_.acceleration_sigma;
  const double dt2 = dt * dt;
  Eigen::Matrix4d noise = Eigen::Matrix4d::Zero();
  for (int axis = 0; axis < 2; ++axis)
  {
    noise(axis, axis) = q * dt2 * dt2 / 4.0;
    noise(axis, axis + 2) = noise(axis + 2, axis) = q * dt2 * dt / 2.0;
    noise(axis + 2, axis + 2) = q * dt2;
  }
  track.state = f * track.state;
  track.covariance = f * track.covariance * f.transpose() + noise;
}

void Tracker::correct(Track& track, const TrackObservation& observation) const
{
  double rp = config_.position_sigma * config_.position_sigma;
  // Beyond robust_sigma (Mahalanobis distance d) the position's noise is inflated by
  // (d / robust_sigma)², so that a jump of the centre estimate moves the track, and
  // feeds its speed, less than a steady displacement does.
  if (config_.robust_sigma > 0.0)
  {
    const double d2 = positionDistance2(track, observation);
    const double k2 = config_.robust_sigma * config_.robust_sigma;
    rp *= std::max(d2 / k2, 1.0);
  }
  if (observation.has_velocity)
  {
    const Eigen::Vector4d z(observation.x, observation.y, observation.vx, observation.vy);
    const double rv = config_.velocity_sigma * config_.velocity_sigma;
    const Eigen::Matrix4d s = track.covariance + Eigen::Vector4d(rp, rp, rv, rv).asDiagonal().toDenseMatrix();
    const Eigen::Matrix4d gain = track.covariance * s.inverse();
    track.state += gain * (z - track.state);
    track.covariance = (Eigen::Matrix4d::Identity() - gain) * track.covariance;
  }
  else
  {
    const Eigen::Vector2d z(observation.x, observation.y);
    const Eigen::Matrix2d s = track.covariance.topLeftCorner<2, 2>() + rp * Eigen::Matrix2d::Identity();
    const Eigen::Matrix<double, 4, 2> gain = track.covariance.leftCols<2>() * s.inverse();
    track.state += gain * (z - track.state.head<2>());
    track.covariance -= gain * track.covariance.topRows<2>();
  }
  track.covariance = 0.5 * (track.covariance + track.covariance.transpose());
}

double Tracker::positionDistance2(const Track& track, const TrackObservation& observation) const
{
  const double rp = config_.position_sigma * config_.position_sigma;
  const Eigen::Matrix2d s = track.covariance.topLeftCorner<2, 2>() + rp * Eigen::Matrix2d::Identity();
  const Eigen::Vector2d innovation(observation.x - track.state(0), observation.y - track.state(1));
  return innovation.dot(s.inverse() * innovation);
}

void Tracker::restart(Track& track, const TrackObservation& observation, double stamp_s) const
{
  const double rp = config_.position_sigma * config_.position_sigma;
  const double vs = observation.has_velocity ? config_.velocity_sigma : config_.initial_speed_sigma;
  track.state << observation.x, observation.y, observation.has_velocity ? observation.vx : 0.0,
      observation.has_velocity ? observation.vy : 0.0;
  track.covariance = Eigen::Vector4d(rp, rp, vs * vs, vs * vs).asDiagonal();
  track.history_start = stamp_s;
  track.restarted = !track.history.empty();  // a jump, not a new track
  if (track.restarted)
  {
    track.before_jump = track.history.back().observed;
  }
  track.history.clear();  // the displacement before a jump says nothing about the speed
}

double Tracker::speedSigma(const Track& track) const
{
  const Eigen::Vector2d v = track.state.tail<2>();
  const Eigen::Matrix2d p = track.covariance.bottomRightCorner<2, 2>();
  const double speed = v.norm();
  if (speed < 1e-9)
  {
    return std::sqrt(0.5 * p.trace());
  }
  return std::sqrt(std::max(0.0, v.dot(p * v)) / (speed * speed));
}

bool Tracker::windowFilled(const Track& track) const
{
  return track.history.size() >= 2 &&
         track.history.back().stamp - track.history.front().stamp >= 0.5 * config_.motion_speed_window;
}

double Tracker::windowSpeed(const Track& track) const
{
  if (!windowFilled(track))
  {
    return 0.0;
  }
  const Sample& oldest = track.history.front();
  const Sample& newest = track.history.back();
  return (newest.filtered - oldest.filtered).norm() / (newest.stamp - oldest.stamp);
}

std::size_t Tracker::middleIndex(const Track& track) const
{
  const double middle_stamp = 0.5 * (track.history.front().stamp + track.history.back().stamp);
  std::size_t middle = 0;
  for (std::size_t i = 1; i < track.history.size(); ++i)
  {
    if (std::abs(track.history[i].stamp - middle_stamp) <
        std::abs(track.history[middle].stamp - middle_stamp))
    {
      middle = i;
    }
  }
  return middle;
}

double Tracker::sustainedSpeed(const Track& track) const
{
  if (!windowFilled(track))
  {
    return 0.0;
  }
  // The observed positions, not the filtered ones: the filter spreads a jump of the centre
  // estimate over the images after it, where it would look like a steady displacement.
  const Sample& oldest = track.history.front();
  const Sample& newest = track.history.back();
  const Sample& middle = track.history[middleIndex(track)];
  const double first_span = middle.stamp - oldest.stamp;
  const double second_span = newest.stamp - middle.stamp;
  if (first_span <= 0.0 || second_span <= 0.0)
  {
    return 0.0;
  }
  const Eigen::Vector2d first = middle.observed - oldest.observed;
  const Eigen::Vector2d second = newest.observed - middle.observed;
  if (first.dot(second) <= 0.0)
  {
    return 0.0;  // back and forth: no displacement that holds
  }
  return std::min(first.norm() / first_span, second.norm() / second_span);
}

double Tracker::steadyDisplacement(const Track& track, std::size_t first, double max_share) const
{
  const std::size_t last = track.history.size() - 1;
  const Eigen::Vector2d displacement = track.history[last].observed - track.history[first].observed;
  const double length = displacement.norm();
  if (!(length > config_.step_tolerance))
  {
    return 0.0;
  }
  for (std::size_t i = first + 1; i <= last; ++i)
  {
    const Eigen::Vector2d step = track.history[i].observed - track.history[i - 1].observed;
    const double step_length = step.norm();
    if ((step_length > config_.step_tolerance && step.dot(displacement) <= 0.0) ||
        step_length > max_share * length)
    {
      return 0.0;
    }
  }
  return length;
}

double Tracker::progressiveSpeed(const Track& track) const
{
  if (!windowFilled(track))
  {
    return 0.0;
  }
  const std::size_t middle = middleIndex(track);
  const std::size_t last = track.history.size() - 1;
  if (last < middle + 3)
  {
    return 0.0;
  }
  return steadyDisplacement(track, middle, 0.5) / (track.history[last].stamp - track.history[middle].stamp);
}

double Tracker::earlySpeed(const Track& track) const
{
  if (!(config_.early_displacement > 0.0) || windowFilled(track) || track.history.size() < 3)
  {
    return 0.0;
  }
  for (const Sample& sample : track.history)
  {
    if (sample.cells < kEarlyMinCells)
    {
      return 0.0;  // a corner or a speck: its centre estimate moves as more of the object shows
    }
  }
  const double moved = steadyDisplacement(track, 0, 0.75);
  if (moved < config_.early_displacement)
  {
    return 0.0;
  }
  return moved / (track.history.back().stamp - track.history.front().stamp);
}

bool Tracker::stillFor(const Track& track, double window) const
{
  const Sample& newest = track.history.back();
  if (!(window > 0.0) || newest.stamp - track.history.front().stamp < window - 1e-6)
  {
    return false;
  }
  double farthest = 0.0;
  for (auto it = track.history.rbegin();
       it != track.history.rend() && newest.stamp - it->stamp <= window + 1e-6; ++it)
  {
    farthest = std::max(farthest, (it->observed - newest.observed).norm());
  }
  return farthest <= 0.5 * config_.motion_speed_threshold * window;
}

bool Tracker::returningAfterJump(const Track& track) const
{
  if (!track.restarted ||
      track.history.back().stamp - track.history_start > config_.motion_speed_window + 1e-9)
  {
    return false;
  }
  const Eigen::Vector2d moved = track.history.back().observed - track.history.front().observed;
  const Eigen::Vector2d back = track.before_jump - track.history.front().observed;
  if (!within45Degrees(moved, back))
  {
    return false;
  }
  // A recovering estimate heads back to the same spot: the position before the jump lies on the
  // line of the displacement, within the estimate's noise (2 σ). One that passes it at a distance
  // is an object moving, whose track had followed another object's cells before the jump (a
  // wall behind a pedestrian).
  const double offset = std::abs(moved.x() * back.y() - moved.y() * back.x()) / moved.norm();
  return offset <= 2.0 * config_.position_sigma;
}

bool Tracker::gridVelocityAgrees(const Track& track, const TrackObservation& observation) const
{
  const Eigen::Vector2d grid(observation.grid_vx, observation.grid_vy);
  if (track.history.size() < 3 || !(grid.norm() > config_.motion_speed_threshold) ||
      observation.grid_cells < static_cast<std::uint32_t>(config_.grid_velocity_min_cells) ||
      observation.grid_velocity_agreement < config_.grid_velocity_agreement)
  {
    return false;
  }
  const Sample& oldest = track.history.front();
  const Sample& newest = track.history.back();
  const Eigen::Vector2d moved = (newest.observed - oldest.observed) / (newest.stamp - oldest.stamp);
  return moved.norm() > 0.5 * config_.motion_speed_threshold && within45Degrees(moved, grid);
}

void Tracker::updateMotion(Track& track, const TrackObservation& observation, double stamp_s) const
{
  track.history.push_back({stamp_s, track.state.head<2>(), Eigen::Vector2d(observation.x, observation.y),
                           observation.grid_cells});
  while (stamp_s - track.history.front().stamp > config_.motion_speed_window + 1e-9)
  {
    track.history.pop_front();
  }
  const double total = static_cast<double>(observation.static_points) + observation.dynamic_points;
  double evidence = 0.0;
  if (total > 0.0)
  {
    evidence = (static_cast<double>(observation.dynamic_points) - observation.static_points) / total;
  }
  if (config_.speed_evidence > 0.0 && windowFilled(track))
  {
    const double filter_speed = track.state.tail<2>().norm();
    const double window_speed = windowSpeed(track);
    // The progressive speed alone: the filter's speed lags a start from rest.
    const double moving_speed =
        std::max(std::min(filter_speed, sustainedSpeed(track)), progressiveSpeed(track));
    if (moving_speed > config_.motion_speed_threshold && !returningAfterJump(track))
    {
      if (config_.speed_overrides_region &&
          stamp_s - track.history_start >= config_.motion_speed_window - 1e-6)
      {
        evidence = std::max(evidence, 0.0);
      }
      evidence += config_.speed_evidence;
    }
    else if (std::max(filter_speed, window_speed) < 0.5 * config_.motion_speed_threshold ||
             stillFor(track, config_.still_window) || stillFor(track, config_.still_short_window))
    {
      evidence -= config_.speed_evidence;
    }
  }
  else if (config_.speed_evidence > 0.0 && earlySpeed(track) > config_.motion_speed_threshold &&
           !returningAfterJump(track))
  {
    evidence += config_.speed_evidence;
  }
  if (config_.grid_velocity_evidence > 0.0 && gridVelocityAgrees(track, observation))
  {
    evidence += config_.grid_velocity_evidence;
  }
  track.motion_score = std::clamp(track.motion_score + evidence, -config_.motion_evidence_limit,
                                  config_.motion_evidence_limit);
  const bool reached = track.motion_score >= config_.motion_switch_evidence ||
                       track.motion_score <= -config_.motion_switch_evidence;
  track.decided = track.decided || reached;
  // A decided track follows its score (hysteresis); until its score first reaches a threshold, a
  // track follows the verdict of each image's region, as the per-frame output does.
  Motion verdict = observation.motion == Motion::kUnknown ? track.motion : observation.motion;
  if (track.decided)
  {
    verdict = track.motion_score >= config_.motion_switch_evidence    ? Motion::kDynamic
              : track.motion_score <= -config_.motion_switch_evidence ? Motion::kStatic
                                                                      : track.motion;
  }
  if (track.motion == Motion::kUnknown)
  {
    track.motion = verdict;  // the first verdict is no change
    return;
  }
  const bool dwelling =
      track.has_motion_change && stamp_s - track.last_motion_change < config_.motion_min_dwell - 1e-9;
  // Evidence at the opposite limit ends the dwell: a verdict taken on thin evidence (an object
  // first seen far away) does not outlast a score that has swung all the way against it.
  const bool saturated = std::abs(track.motion_score) >= config_.motion_evidence_limit - 1e-9;
  if (verdict != track.motion && verdict != Motion::kUnknown && (!dwelling || saturated))
  {
    track.has_motion_change = true;
    track.last_motion_change = stamp_s;
    track.motion = verdict;
  }
}

TrackEstimate Tracker::estimateOf(const Track& track, double stamp_s) const
{
  TrackEstimate e;
  e.confirmed = track.confirmed;
  e.id = track.id;
  e.motion = track.motion;
  e.x = track.state(0);
  e.y = track.state(1);
  e.vx = track.state(2);
  e.vy = track.state(3);
  e.speed_sigma = speedSigma(track);
  e.window_speed = windowSpeed(track);
  e.motion_score = track.motion_score;
  e.hits = track.hits;
  e.age = stamp_s - track.first_stamp;
  return e;
}

std::vector<TrackEstimate> Tracker::update(double stamp_s, const std::vector<TrackObservation>& observations)
{
  if (has_stamp_ && (stamp_s < last_stamp_ || stamp_s - last_stamp_ > config_.max_gap))
  {
    reset();
  }
  const double dt = has_stamp_ ? stamp_s - last_stamp_ : 0.0;
  has_stamp_ = true;
  last_stamp_ = stamp_s;
  for (Track& track : tracks_)
  {
    predict(track, dt);
  }

  // Association: gate, cost, optimal assignment.
  const double gate2 = config_.gate_sigma * config_.gate_sigma;
  CostMatrix cost(tracks_.size(), observations.size());
  for (std::size_t t = 0; t < tracks_.size(); ++t)
  {
    const Track& track = tracks_[t];
    for (std::size_t o = 0; o < observations.size(); ++o)
    {
      const TrackObservation& obs = observations[o];
      if (obs.label != track.label)
      {
        continue;
      }
      const double d2 = positionDistance2(track, obs);
      const double iou = boxOverlap(obs.box, track.box);
      if (!(d2 <= gate2) && !(iou >= config_.min_iou))
      {
        continue;
      }
      // A pair admitted by its overlap alone costs as much as one at the edge of the gate.
      cost.at(t, o) = std::min(d2, gate2) / gate2 + config_.iou_weight * (1.0 - iou);
    }
  }
  const std::vector<std::size_t> match = solveAssignment(cost);

  std::vector<std::size_t> track_of(observations.size(), kUnassigned);
  for (std::size_t t = 0; t < tracks_.size(); ++t)
  {
    Track& track = tracks_[t];
    if (match[t] == kUnassigned)
    {
      ++track.misses;
      continue;
    }
    const TrackObservation& obs = observations[match[t]];
    if (positionDistance2(track, obs) <= gate2)
    {
      correct(track, obs);
    }
    else
    {
      // Admitted by its box alone: the position jumped (the estimate of a partly hidden object, or
      // another object's cells). Restart the state there rather than bend the velocity to it.
      restart(track, obs, stamp_s);
    }
    updateMotion(track, obs, stamp_s);
    track.box = obs.box;
    ++track.hits;
    track.misses = 0;
    track.confirmed = track.confirmed || track.hits >= config_.min_hits;
    track_of[match[t]] = t;
  }
  for (std::size_t o = 0; o < observations.size(); ++o)
  {
    if (track_of[o] != kUnassigned)
    {
      continue;
    }
    const TrackObservation& obs = observations[o];
    Track track;
    track.id = next_id_++;
    track.label = obs.label;
    restart(track, obs, stamp_s);
    track.box = obs.box;
    track.hits = 1;
    track.confirmed = config_.min_hits <= 1;
    track.first_stamp = stamp_s;
    updateMotion(track, obs, stamp_s);
    track_of[o] = tracks_.size();
    tracks_.push_back(std::move(track));
  }

  std::vector<TrackEstimate> estimates;
  estimates.reserve(observations.size());
  for (std::size_t o = 0; o < observations.size(); ++o)
  {
    estimates.push_back(estimateOf(tracks_[track_of[o]], stamp_s));
  }
  tracks_.erase(std::remove_if(tracks_.begin(), tracks_.end(),
                               [&](const Track& track)
                               { return track.misses > (track.confirmed ? config_.max_misses : 0); }),
                tracks_.end());
  return estimates;
}

void trackObjects(Tracker& tracker, double stamp_s, const std::vector<Detection>& detections,
                  FusionResult& result)
{
  std::vector<TrackObservation> observations;
  observations.reserve(result.objects.size());
  for (const FusedObject& object : result.objects)
  {
    const Detection& detection = detections.at(object.detection_index);
    TrackObservation o;
    o.label = detection.label;
    o.box = detection.box;
    o.x = object.x;
    o.y = object.y;
    o.has_velocity = object.motion == Motion::kDynamic;
    o.vx = object.vx;
    o.vy = object.vy;
    o.static_points = object.static_points;
    o.dynamic_points = object.dynamic_points;
    o.motion = object.motion;
    o.grid_vx = object.grid_vx;
    o.grid_vy = object.grid_vy;
    o.grid_velocity_agreement = object.grid_velocity_agreement;
    o.grid_cells = static_cast<std::uint32_t>(object.cluster.size());
    observations.push_back(std::move(o));
  }
  const std::vector<TrackEstimate> estimates = tracker.update(stamp_s, observations);
  std::vector<FusedObject> kept;
  kept.reserve(result.objects.size());
  result.tentative.clear();
  for (std::size_t i = 0; i < result.objects.size(); ++i)
  {
    FusedObject& object = result.objects[i];
    const TrackEstimate& track = estimates[i];
    if (!track.confirmed)
    {
      result.tentative.push_back(object.detection_index);
      continue;
    }
    object.id = track.id;
    object.motion = track.motion;
    object.x = track.x;
    object.y = track.y;
    const bool dynamic = track.motion == Motion::kDynamic;
    object.vx = dynamic ? track.vx : 0.0;
    object.vy = dynamic ? track.vy : 0.0;
    object.heading = dynamic ? std::atan2(track.vy, track.vx) : 0.0;
    kept.push_back(std::move(object));
  }
  result.objects = std::move(kept);
  result.tracked = true;
}

}  // namespace grid_vision_fusion
