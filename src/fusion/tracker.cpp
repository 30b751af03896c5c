#include "grid_vision_fusion/fusion/tracker.h"

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <deque>
#include <sstream>
#include <stdexcept>
#include <utility>

#include "grid_vision_fusion/fusion/assignment.h"
#include "grid_vision_fusion/fusion/model_constants.h"

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

/// Drops from `hits` (oldest first, each with a `stamp` [s]) those older than the registration's
/// span before `stamp_s` [s].
template <typename Hits>
void dropBeforeSpan(std::deque<Hits>& hits, double stamp_s)
{
  const double oldest = stamp_s - kRegistrationSpan - kRegistrationSlack;
  while (!hits.empty() && hits.front().stamp < oldest)
  {
    hits.pop_front();
  }
}

/// The edges (x_min, y_min, x_max, y_max) of `box` [px].
Eigen::Vector4d edgesOf(const BoundingBox& box)
{
  return Eigen::Vector4d(box.x_min, box.y_min, box.x_max, box.y_max);
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
  requirePositive("track_position_sigma", position_sigma);
  requirePositive("track_max_gap", max_gap);
  if (!(box_gain > 0.0 && box_gain <= 1.0))
  {
    throw std::invalid_argument("track_box_gain must be in (0, 1], got " + std::to_string(box_gain));
  }
  motion.validate();
  for (const auto& [label, sigma] : class_speed_sigmas)
  {
    if (label.empty())
    {
      throw std::invalid_argument("motion_class_speed_sigmas: a label is empty");
    }
    requirePositive(("motion_class_speed_sigmas/" + label).c_str(), sigma);
  }
}

MotionModelConfig TrackerConfig::motionFor(const std::string& label) const
{
  MotionModelConfig config = motion;
  const auto sigma = class_speed_sigmas.find(label);
  if (sigma != class_speed_sigmas.end())
  {
    config.speed_sigma = sigma->second;
  }
  return config;
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
  for (Track& track : tracks_)
  {
    track.motion.setConfig(config_.motionFor(majorityLabel(track)));
  }
}

std::string Tracker::resetReason(double stamp_s) const
{
  const double gap = stamp_s - last_stamp_;
  if (!has_stamp_ || (gap >= 0.0 && gap <= config_.max_gap))
  {
    return {};
  }
  return gap < 0.0 ? "time jumped backwards by " + std::to_string(-gap) + " s"
                   : "gap of " + std::to_string(gap) + " s since the last pair exceeds track_max_gap (" +
                         std::to_string(config_.max_gap) + " s)";
}

void Tracker::reset()
{
  tracks_.clear();
  scene_hits_.clear();
  has_stamp_ = false;
  last_camera_ = Eigen::Vector2d::Constant(kNotKnown);
  camera_speed_ = kNotKnown;
}

Eigen::Matrix2d Tracker::cutNoise(const TrackObservation& observation) const
{
  if (!observation.truncated)
  {
    return Eigen::Matrix2d::Zero();
  }
  // The image edge sweeps along a standing object as fast as the camera moves: over the span the
  // hits are registered across, that far; a camera that stands still shows a fixed window of it.
  const double half = 0.5 * observation.length;
  const double offset =
      std::isfinite(camera_speed_) ? std::min(half, camera_speed_ * kRegistrationSpan) : half;
  return offset * offset * Eigen::Matrix2d::Identity();
}

double Tracker::positionDistance2(const Track& track, const TrackObservation& observation) const
{
  const Eigen::Matrix2d noise =
      config_.position_sigma * config_.position_sigma * Eigen::Matrix2d::Identity() + cutNoise(observation);
  return track.motion.distance2(Eigen::Vector2d(observation.x, observation.y), noise);
}

std::vector<TrackPrior> Tracker::priors(double stamp_s, const std::vector<Detection>& detections) const
{
  std::vector<TrackPrior> priors(detections.size());
  const bool continuing = has_stamp_ && stamp_s >= last_stamp_ && stamp_s - last_stamp_ <= config_.max_gap;
  for (std::size_t d = 0; continuing && d < detections.size(); ++d)
  {
    const Track* best = nullptr;
    double best_iou = config_.min_iou;
    for (const Track& track : tracks_)
    {
      const double iou = boxOverlap(detections[d].box, track.box);
      if (iou >= best_iou && groupOf(detections[d].label) == track.group)
      {
        best = &track;
        best_iou = iou;
      }
    }
    if (best == nullptr)
    {
      continue;
    }
    TrackPrior& prior = priors[d];
    const Eigen::Vector2d shift = best->motion.state().tail<2>() * (stamp_s - best->last_seen);
    for (const Eigen::Vector2d& cell : best->cells)
    {
      prior.cells.push_back(cell + shift);
    }
    // A track without cells yet has filtered only boxes whose band held none: its first band with
    // cells hangs on the detector's box (updateTrack()).
    prior.box = best->located ? filteredBox(*best, detections[d].box, stamp_s).box() : detections[d].box;
    prior.has_box = true;
    prior.label = majorityLabel(*best);
  }
  return priors;
}

BoundingBox Tracker::BoxFilter::box() const
{
  return BoundingBox{static_cast<float>(edges(0)), static_cast<float>(edges(1)), static_cast<float>(edges(2)),
                     static_cast<float>(edges(3))};
}

Tracker::BoxFilter Tracker::BoxFilter::at(const BoundingBox& box)
{
  BoxFilter filter;
  filter.edges = edgesOf(box);
  return filter;
}

Tracker::BoxFilter Tracker::filteredBox(const Track& track, const BoundingBox& box, double stamp_s) const
{
  const Eigen::Vector4d measured = edgesOf(box);
  const double dt = stamp_s - track.last_seen;
  BoxFilter filter = track.box_filter;
  if (!(dt > 0.0))
  {
    filter.edges = measured;
    return filter;
  }
  const double alpha = config_.box_gain;
  const double beta = alpha * alpha / (2.0 - alpha);
  const Eigen::Vector4d predicted = filter.edges + filter.rates * dt;
  const Eigen::Vector4d residual = measured - predicted;
  filter.edges = predicted + alpha * residual;
  // The first step has no rate yet: it starts from the two boxes' difference.
  filter.rates = filter.has_rates ? Eigen::Vector4d(filter.rates + beta / dt * residual)
                                  : Eigen::Vector4d(residual / dt);
  filter.has_rates = true;
  // A filter that lost the box's shape (edges crossed) gives way to the detector's box.
  if (!filter.edges.allFinite() || filter.edges(2) <= filter.edges(0) || filter.edges(3) <= filter.edges(1))
  {
    filter = BoxFilter::at(box);
  }
  return filter;
}

const std::string& Tracker::majorityLabel(const Track& track)
{
  return std::max_element(track.label_votes.begin(), track.label_votes.end(),
                          [](const auto& a, const auto& b) { return a.second < b.second; })
      ->first;
}

const std::string& Tracker::groupOf(const std::string& label) const
{
  const auto group = config_.label_groups.find(label);
  return group == config_.label_groups.end() ? label : group->second;
}

TrackEstimate Tracker::estimateOf(const Track& track) const
{
  TrackEstimate e;
  e.confirmed = track.confirmed;
  e.id = track.id;
  e.label = majorityLabel(track);
  e.class_id = track.label_classes.at(e.label);
  e.p_dynamic = track.motion.pDynamic(track.evidence);
  e.motion = e.p_dynamic > 0.5 ? Motion::kDynamic : e.p_dynamic < 0.5 ? Motion::kStatic : Motion::kUnknown;
  const Eigen::Vector4d state = track.motion.state();
  e.x = state(0);
  e.y = state(1);
  const Eigen::Vector2d velocity = track.motion.movingVelocity();
  e.vx = velocity.x();
  e.vy = velocity.y();
  e.located = track.located;
  return e;
}

std::vector<TrackEstimate> Tracker::update(double stamp_s, const std::vector<TrackObservation>& observations,
                                           std::vector<Eigen::Vector2d> scene_hits,
                                           const Eigen::Vector2d& camera)
{
  if (!resetReason(stamp_s).empty())
  {
    reset();
  }
  const double dt = has_stamp_ ? stamp_s - last_stamp_ : 0.0;
  camera_speed_ = dt > 0.0 && camera.allFinite() && last_camera_.allFinite()
                      ? (camera - last_camera_).norm() / dt
                      : kNotKnown;
  last_camera_ = camera;
  has_stamp_ = true;
  last_stamp_ = stamp_s;
  for (Track& track : tracks_)
  {
    track.motion.predict(dt);
    track.evidence = MotionEvidence();  // the last image's
  }
  dropBeforeSpan(scene_hits_, stamp_s);  // before new tracks take their hits of the scans before
  const std::vector<std::size_t> match = associate(observations);
  std::vector<std::size_t> track_of(observations.size(), kUnassigned);
  for (std::size_t t = 0; t < tracks_.size(); ++t)
  {
    if (match[t] == kUnassigned)
    {
      ++tracks_[t].misses;
      continue;
    }
    updateTrack(tracks_[t], observations[match[t]]);
    track_of[match[t]] = t;
  }
  for (std::size_t o = 0; o < observations.size(); ++o)
  {
    if (track_of[o] == kUnassigned)
    {
      track_of[o] = tracks_.size();
      tracks_.push_back(newTrack(observations[o], stamp_s));
    }
  }

  std::vector<TrackEstimate> estimates;
  estimates.reserve(observations.size());
  for (std::size_t o = 0; o < observations.size(); ++o)
  {
    estimates.push_back(estimateOf(tracks_[track_of[o]]));
  }
  tracks_.erase(std::remove_if(tracks_.begin(), tracks_.end(),
                               [&](const Track& track) { return track.misses > config_.max_misses; }),
                tracks_.end());
  scene_hits_.push_back({stamp_s, std::move(scene_hits)});
  return estimates;
}

std::vector<std::size_t> Tracker::associate(const std::vector<TrackObservation>& observations) const
{
  const double gate2 = config_.gate_sigma * config_.gate_sigma;
  CostMatrix cost(tracks_.size(), observations.size());
  for (std::size_t t = 0; t < tracks_.size(); ++t)
  {
    const Track& track = tracks_[t];
    for (std::size_t o = 0; o < observations.size(); ++o)
    {
      const TrackObservation& obs = observations[o];
      if (groupOf(obs.label) != track.group)
      {
        continue;
      }
      // An object without cells has only its box's rough position: its box alone admits it.
      const double d2 = obs.supported && track.located ? positionDistance2(track, obs) : gate2;
      const double iou = boxOverlap(obs.box, track.box);
      if (!(d2 < gate2) && !(iou >= config_.min_iou))
      {
        continue;
      }
      // A pair admitted by its overlap alone costs as much as one at the edge of the gate.
      cost.at(t, o) = std::min(d2, gate2) / gate2 + config_.iou_weight * (1.0 - iou);
    }
  }
  return solveAssignment(cost);
}

void Tracker::updateTrack(Track& track, const TrackObservation& obs) const
{
  const bool was_located = track.located;
  if (!obs.supported)
  {
    // No cell: the motion model only predicts; the cells the track expects move on with it.
    const Eigen::Vector2d shift = track.motion.state().tail<2>() * (last_stamp_ - track.last_seen);
    for (Eigen::Vector2d& cell : track.cells)
    {
      cell += shift;
    }
  }
  else if (track.located)
  {
    updateMotion(track, obs);
  }
  else
  {
    locate(track, obs);
  }
  if (was_located)
  {
    track.box_filter = filteredBox(track, obs.box, last_stamp_);
  }
  else
  {
    // The box filter starts with the track's first cells. Boxes without cells before them (an
    // object beyond the lidar's reach, a box entering at the image edge) keep the track and its
    // association, but not its filter: their edges' rates lag where the box grows fastest (an
    // object approached, or coming into view), the first images with cells, and a band hung on
    // that lag misses the object's cells when its first centres set its motion model.
    track.box_filter = BoxFilter::at(obs.box);
  }
  track.last_seen = last_stamp_;
  track.label_votes[obs.label] += obs.score;
  track.label_classes[obs.label] = obs.class_id;
  track.box = obs.box;
  ++track.hits;
  track.misses = 0;
  track.confirmed = track.confirmed || track.hits >= config_.min_hits;
}

void Tracker::updateMotion(Track& track, const TrackObservation& obs) const
{
  const Eigen::Vector2d centre(obs.x, obs.y);
  // A track seen once has no estimate for its centre to jump from, only one centre and no
  // velocity: its second centre, wherever it lies, is its first step (a car at 20 m/s moves 2 m
  // between two images, beyond the gate of the prior speed).
  const bool first_step = track.centres == 1;
  if (!first_step && !(positionDistance2(track, obs) <= config_.gate_sigma * config_.gate_sigma))
  {
    // Admitted by its box alone: the centre estimate jumped (a partly hidden object, another
    // object's cells, a cut box whose outline turned). Restart the filters there, keeping what
    // they knew of the motion.
    track.motion.restartAt(centre);
  }
  else
  {
    // A box cut by the image edge: along the object's length its centre follows the visible part.
    track.motion.update(centre, cutNoise(obs));
  }
  track.evidence.grid = track.motion.updateGrid(obs.grid);
  registerHits(track, obs);
  track.cells = obs.cells;
  ++track.centres;
}

void Tracker::locate(Track& track, const TrackObservation& obs) const
{
  track.motion.start(Eigen::Vector2d(obs.x, obs.y), 0.5);
  track.evidence.grid = track.motion.updateGrid(obs.grid);
  // A new object's hits are in the scans before its first image, if the lidar saw it: its first
  // hits register against them. A track whose boxes came without cells first was in the camera's
  // view but not in the lidar's (hidden from it by an occluder, or beyond its reach): the scans
  // of those images hold what stood around its place, not its hits, and a neighbour of its shape
  // there (the next parked car) would register as its displacement. It registers against its own
  // hits only.
  const bool seen_without_cells = last_stamp_ > track.first_stamp;
  track.recent_hits = seen_without_cells ? std::deque<ObservedHits>() : hitsBefore(obs, track.motion);
  registerHits(track, obs);
  track.cells = obs.cells;
  track.located = true;
  track.centres = 1;
}

void Tracker::registerHits(Track& track, const TrackObservation& obs) const
{
  dropBeforeSpan(track.recent_hits, last_stamp_);
  if (!track.recent_hits.empty())
  {
    // A cut box's hits are those the image still shows: a window that slides along the object's
    // length, over which they say nothing (cutNoise(), as for its centre).
    const ObservedHits& then = track.recent_hits.front();
    track.evidence.registration = track.motion.registrationEvidence(then.cells, obs.hits, obs.cell_size,
                                                                    last_stamp_ - then.stamp, cutNoise(obs));
  }
  track.recent_hits.push_back({last_stamp_, obs.hits});
}

Tracker::Track Tracker::newTrack(const TrackObservation& obs, double stamp_s)
{
  Track track;
  track.id = next_id_++;
  track.group = groupOf(obs.label);
  track.motion = MotionModel(config_.motionFor(obs.label));
  track.box = obs.box;
  track.box_filter = BoxFilter::at(obs.box);
  track.label_votes[obs.label] = obs.score;
  track.label_classes[obs.label] = obs.class_id;
  track.last_seen = stamp_s;
  track.hits = 1;
  track.confirmed = config_.min_hits <= 1;
  track.first_stamp = stamp_s;
  if (obs.supported)
  {
    locate(track, obs);
  }
  return track;
}

std::deque<Tracker::ObservedHits> Tracker::hitsBefore(const TrackObservation& obs,
                                                      const MotionModel& motion) const
{
  std::deque<ObservedHits> before;
  if (obs.hits.empty() || !(obs.cell_size > 0.0))
  {
    return before;  // nothing to register
  }
  Eigen::Vector2d low = obs.hits.front();
  Eigen::Vector2d high = low;
  for (const Eigen::Vector2d& hit : obs.hits)
  {
    low = low.cwiseMin(hit);
    high = high.cwiseMax(hit);
  }
  const Eigen::Matrix2d unseen = cutNoise(obs);
  for (const ObservedHits& scan : scene_hits_)
  {
    const double reach = registrationReach(obs.cell_size, last_stamp_ - scan.stamp, motion.movingVelocity(),
                                           motion.movingVelocityCovariance(), unseen);
    ObservedHits near{scan.stamp, {}};
    for (const Eigen::Vector2d& hit : scan.cells)
    {
      if ((hit.array() >= low.array() - reach).all() && (hit.array() <= high.array() + reach).all())
      {
        near.cells.push_back(hit);
      }
    }
    before.push_back(std::move(near));
  }
  return before;
}

}  // namespace grid_vision_fusion
