// Multi-object tracking of the fused objects: objects that persist from image to image with a
// stable id, a constant-velocity Kalman filter per track in the fixed (grid) frame, and a motion
// verdict that accumulates the evidence of several frames with hysteresis.
//
// Per image (Tracker::update): every track is predicted to the image stamp; tracks and fused
// objects are associated by an optimal assignment (solveAssignment()) of the pairs that pass the
// gate (same label, and the object within gate_sigma of the track's predicted position, or its
// box overlapping the track's last box by min_iou or more); the cost of a pair is its squared
// Mahalanobis distance over gate_sigma² plus iou_weight · (1 − IoU). A matched track is updated
// with the object's position (and the grid's velocity when the object's region is dynamic), or,
// when the object passed the gate by its box alone, restarted at the object's position; an
// object left over starts a tentative track, which becomes confirmed after min_hits hits and is
// dropped at its first miss; a confirmed track is dropped after more than max_misses consecutive
// misses. Only confirmed tracks that were matched in this image are reported.
#pragma once

#include <Eigen/Core>

#include <cstddef>
#include <cstdint>
#include <deque>
#include <string>
#include <vector>

#include "grid_vision_fusion/fusion/fusion.h"
#include "grid_vision_fusion/types.h"

namespace grid_vision_fusion
{
/// Parameters of the tracker.
struct TrackerConfig
{
  int min_hits = 2;    ///< hits (images with a matched object) that confirm a track, >= 1
  int max_misses = 5;  ///< a confirmed track is dropped after more consecutive misses, >= 0
  /// Gate on the predicted position: squared Mahalanobis distance <= gate_sigma² [σ], > 0.
  double gate_sigma = 3.0;
  /// Boxes overlapping the track's last box by this IoU or more pass the gate whatever their
  /// position, (0, 1]; a second cue where the position estimate jumps (an object partly hidden).
  double min_iou = 0.3;
  double iou_weight = 1.0;           ///< weight of (1 − IoU) in the association cost, >= 0
  double acceleration_sigma = 2.0;   ///< process noise: white acceleration [m/s²], > 0
  double position_sigma = 0.5;       ///< noise of a position measurement [m], > 0
  double velocity_sigma = 1.0;       ///< noise of the grid's velocity of a dynamic region [m/s], > 0
  double initial_speed_sigma = 5.0;  ///< velocity uncertainty of a new track without one [m/s], > 0
  double max_gap = 1.0;  ///< more time between two images [s], or time going back, resets the tracks
  /// Robust update: a position farther than robust_sigma (Mahalanobis, [σ]) from the
  /// prediction has its noise inflated by (distance / robust_sigma)², so that a jump of the centre estimate
  /// (the visible part of an object changing) moves the track, and its speed, less than a
  /// steady displacement. 0: the plain Kalman update. >= 0.
  double robust_sigma = 0.0;
  /// Motion evidence: every image adds the region's evidence (d − s)/(d + s) of its static and
  /// dynamic cell counts, plus speed_evidence (below), to the track's score, which is clamped to
  /// ±motion_evidence_limit. The verdict turns dynamic when the score reaches
  /// +motion_switch_evidence and static when it reaches −motion_switch_evidence; in between it
  /// keeps the last verdict (hysteresis). Until its score first reaches a threshold, a new track
  /// takes the verdict of each image's region (the per-frame output's).
  double motion_evidence_limit = 2.0;   ///< > 0
  double motion_switch_evidence = 1.5;  ///< in (0, motion_evidence_limit]
  /// After a change (of either kind), the verdict holds for at least this long [s], >= 0: no
  /// flicker faster — unless the score reaches the opposite limit (±motion_evidence_limit), so
  /// that a verdict taken on thin evidence (an object first seen far away) does not outlast
  /// evidence that has swung all the way against it.
  double motion_min_dwell = 2.0;
  /// Weight of the track's own motion as evidence, >= 0 (0: the grid's evidence only): +weight
  /// when both the filter's speed and the sustained speed (the smaller of the average speeds of
  /// the observed position over the two halves of the last motion_speed_window, 0 when their
  /// directions differ by more than 90°: a jump of the centre estimate falls into one half only)
  /// exceed motion_speed_threshold, or the progressive speed does (the observed position's over
  /// the second half alone, when it never steps back and none by more than half of the way: a
  /// start from rest, which the filter's speed lags), −weight when both the filter's speed and
  /// the average speed of the filtered position over the window are below half of it (or the
  /// observed position has stayed still, still_window and still_short_window). Needs a track
  /// older than half the window (younger ones: early_displacement); no +weight while the
  /// observed position, after a restart (a jump of the centre estimate), heads back to where it
  /// was before the jump (passing it within 2 position_sigma): the estimate recovering, not the
  /// object moving. Above 1 it outweighs a region vote that leans static: the grid does not
  /// resolve motion slower than about a cell per scan, whose cells stay occupied and turn static.
  double speed_evidence = 2.0;
  /// [m/s], > 0. Below the 1 m/s that counts as moving: the sustained speed, a minimum of two
  /// noisy averages, reads low.
  double motion_speed_threshold = 0.8;
  double motion_speed_window = 1.0;  ///< [s], > 0
  /// Weight of the grid's velocity as evidence, >= 0 (0: off): +weight per image when the
  /// object's cells agree on one velocity (grid_velocity_agreement of at least
  /// grid_velocity_min_cells cells, FusedObject) faster than motion_speed_threshold and the
  /// track's observed position has moved the same way (within 45°, at least half the threshold,
  /// over at least 3 images). The particles of a moving object's cells carry its velocity a few
  /// scans after it appears, while its mass is still split between static and dynamic (a new
  /// track, the first second of a drive, the long side of a vehicle).
  double grid_velocity_evidence = 2.5;
  double grid_velocity_agreement = 0.5;  ///< share of the cells, (0, 1]
  int grid_velocity_min_cells = 4;       ///< >= 1
  /// A young track, before the speed tests above can judge it (its history spans less than half
  /// of motion_speed_window), gets +speed_evidence when its observed position has moved at least
  /// this far [m], faster than motion_speed_threshold and steadily: over 2 steps or more, none
  /// going back, none longer than 3/4 of the way (a jump of the centre estimate is one long
  /// step; an image with fewer than 3 cells of the object gives no position to count from). A
  /// car at 10 m/s is known in its third image instead of its sixth. 0: off. >= 0.
  double early_displacement = 1.0;
  /// −speed_evidence also when the observed position has stayed within half of
  /// motion_speed_threshold × still_window of where it is now over the last still_window [s]: a
  /// stop, which the filter's speed and the window's average see only a second later. 0: off.
  /// [0, motion_speed_window].
  double still_window = 0.5;
  /// The same test over this shorter window as well [s]: the centre has moved less than half a
  /// cell in two scans. It sees the end of a stop 0.2–0.3 s sooner: an object slowing down
  /// through the last 0.5 m/s, whose observed position also jitters by a cell now and then,
  /// rarely stays within 0.2 m for a whole 0.5 s before it stands. A moving object's observed
  /// position moves on within two scans (faster than the threshold, more than 0.16 m). 0: off.
  /// [0, motion_speed_window].
  double still_short_window = 0.2;
  /// A step of the observed position shorter than this [m] does not count as a step back in the
  /// tests of a steady displacement (progressive and early speed): the centre estimate's jitter
  /// of a few centimetres (its orientation fit) is no reversal. >= 0.
  double step_tolerance = 0.05;
  /// A track older than motion_speed_window (since its birth or its last restart) whose own
  /// speed gives +speed_evidence has its region's static vote dropped from that image's
  /// evidence: the grid does not resolve motion slower than about a cell per scan, whose cells it
  /// calls static, so a static vote does not speak against a displacement the track has
  /// measured. A dynamic vote still counts. Younger tracks keep the vote: their displacement may
  /// still be the centre estimate settling while more of the object comes into view. false: the
  /// region's vote always counts.
  bool speed_overrides_region = true;

  /// @throws std::invalid_argument naming the first bad field (as the ranges above).
  void validate() const;
};

/// One fused object of an image, as the tracker sees it.
struct TrackObservation
{
  std::string label;  ///< the detector's class; only tracks of the same label are associated
  BoundingBox box;    ///< the detector box [px]
  double x = 0.0;     ///< position [m], fixed frame
  double y = 0.0;
  bool has_velocity = false;  ///< the region is dynamic: vx, vy are the grid's velocity
  double vx = 0.0;            ///< [m/s], fixed frame
  double vy = 0.0;
  std::uint32_t static_points = 0;   ///< static cells of the region
  std::uint32_t dynamic_points = 0;  ///< dynamic cells of the region
  Motion motion = Motion::kUnknown;  ///< the region's own verdict (the paper's)
  double grid_vx = 0.0;              ///< the grid's velocity of the object [m/s] (FusedObject::grid_vx)
  double grid_vy = 0.0;
  double grid_velocity_agreement = 0.0;  ///< share of its cells that agree on it, [0, 1]
  std::uint32_t grid_cells = 0;          ///< cells of the object's cluster
};

/// What the tracker says about one observation of the image.
struct TrackEstimate
{
  bool confirmed = false;            ///< the observation belongs to a confirmed track: report it
  std::uint32_t id = 0;              ///< track id, unique over the tracker's life, from 1
  Motion motion = Motion::kUnknown;  ///< the track's verdict
  double x = 0.0;                    ///< filtered position [m]
  double y = 0.0;
  double vx = 0.0;  ///< filtered velocity [m/s]
  double vy = 0.0;
  double speed_sigma = 0.0;  ///< standard deviation of the speed estimate [m/s]
  /// Average speed over the last motion_speed_window (displacement of the filtered position),
  /// 0 for a track younger than half of it [m/s].
  double window_speed = 0.0;
  double motion_score = 0.0;  ///< accumulated motion evidence (> 0 dynamic)
  int hits = 0;               ///< images with an observation, this one included
  double age = 0.0;           ///< time since the track's first observation [s]
};

/// The tracker. Deterministic; not thread-safe.
class Tracker
{
public:
  /// @throws std::invalid_argument when `config` is invalid.
  explicit Tracker(const TrackerConfig& config = TrackerConfig());

  /// Processes the observations of the image at `stamp_s` [s]: one estimate per observation,
  /// in the same order. Stamps must increase; a stamp earlier than the last one, or later by
  /// more than max_gap, first drops every track (ids keep counting up).
  std::vector<TrackEstimate> update(double stamp_s, const std::vector<TrackObservation>& observations);

  /// Replaces the configuration; the tracks are kept. @throws std::invalid_argument as the
  /// constructor, leaving the configuration unchanged.
  void setConfig(const TrackerConfig& config);
  const TrackerConfig& config() const { return config_; }

  /// Drops every track (ids keep counting up).
  void reset();
  /// Tracks alive (tentative and confirmed).
  std::size_t size() const { return tracks_.size(); }

private:
  /// One image of a track: its stamp [s], the filtered and the observed (unfiltered) position.
  struct Sample
  {
    double stamp = 0.0;
    Eigen::Vector2d filtered;
    Eigen::Vector2d observed;
    std::uint32_t cells = 0;  ///< cells of the object's cluster
  };

  struct Track
  {
    std::uint32_t id = 0;
    std::string label;
    Eigen::Vector4d state = Eigen::Vector4d::Zero();  ///< x, y, vx, vy
    Eigen::Matrix4d covariance = Eigen::Matrix4d::Identity();
    BoundingBox box;
    int hits = 0;
    int misses = 0;
    bool confirmed = false;
    double first_stamp = 0.0;
    double motion_score = 0.0;
    Motion motion = Motion::kUnknown;
    bool decided = false;  ///< the motion score has reached a threshold once
    bool has_motion_change = false;
    double last_motion_change = 0.0;  ///< stamp of the last verdict change [s]
    /// The images of the last motion_speed_window, oldest first.
    std::deque<Sample> history;
    double history_start = 0.0;  ///< stamp of the track's birth or last restart [s]
    bool restarted = false;      ///< history_start is a restart after a jump of the centre estimate...
    Eigen::Vector2d before_jump = Eigen::Vector2d::Zero();  ///< ...from this observed position
  };

  void predict(Track& track, double dt) const;
  void correct(Track& track, const TrackObservation& observation) const;
  /// Squared Mahalanobis distance of the observation's position from the track's prediction.
  double positionDistance2(const Track& track, const TrackObservation& observation) const;
  /// Sets the state to the observation (position, the grid's velocity or zero) with the initial
  /// uncertainty: a new track, or a track whose object was admitted by its box overlap alone (a
  /// jump at `stamp_s`, remembered for returningAfterJump()).
  void restart(Track& track, const TrackObservation& observation, double stamp_s) const;
  void updateMotion(Track& track, const TrackObservation& observation, double stamp_s) const;
  double speedSigma(const Track& track) const;
  /// The track's history spans at least half of motion_speed_window: its speeds count.
  bool windowFilled(const Track& track) const;
  /// Average speed over the track's history (0 while it spans less than half the window).
  double windowSpeed(const Track& track) const;
  /// The smaller of the average speeds of the observed positions over the two halves of the
  /// history, 0 when they point more than 90° apart or the history is too short: a steady
  /// displacement passes, a single jump of the centre estimate (which falls into one half) does
  /// not.
  double sustainedSpeed(const Track& track) const;
  /// A start from rest, which the sustained speed sees only half a window later: the average
  /// speed of the observed position over the second half of the history when it has moved
  /// steadily (steadyDisplacement(): at least 3 steps, none back — a step of zero is a slow
  /// object within its cell — none by more than half of the way: a jump of the centre estimate
  /// is one big step, and noise around a standing object steps back and forth); 0 otherwise.
  /// The observed, not the filtered, positions: the filter lags a start.
  double progressiveSpeed(const Track& track) const;
  /// The speed of a young track (history shorter than half the window) whose observed position
  /// has moved steadily by early_displacement or more (steadyDisplacement() from the oldest
  /// entry, steps of at most 3/4), each of its images seeing at least 3 cells of the object; 0
  /// otherwise.
  double earlySpeed(const Track& track) const;
  /// The length of the observed displacement from history[first] to the newest entry when it
  /// went steadily: no step goes back along it (a step shorter than step_tolerance is none),
  /// none is longer than max_share of it; 0 otherwise.
  double steadyDisplacement(const Track& track, std::size_t first, double max_share) const;
  /// The observed position has stayed within half of motion_speed_threshold × `window` of where
  /// it is now over the last `window` [s] (false for `window` <= 0 or a shorter track).
  bool stillFor(const Track& track, double window) const;
  /// The observed position has been heading back to where it was before the track's last
  /// restart (within 45°, and passing that position within 2 track_position_sigma), within
  /// motion_speed_window of it.
  bool returningAfterJump(const Track& track) const;
  /// The grid's velocity evidence of grid_velocity_evidence holds for this observation.
  bool gridVelocityAgrees(const Track& track, const TrackObservation& observation) const;
  /// Index in the history of the entry nearest to the middle of its span.
  std::size_t middleIndex(const Track& track) const;
  TrackEstimate estimateOf(const Track& track, double stamp_s) const;

  TrackerConfig config_;
  std::vector<Track> tracks_;
  std::uint32_t next_id_ = 1;
  bool has_stamp_ = false;
  double last_stamp_ = 0.0;
};

/// Runs `tracker` on the objects of `result` at `stamp_s` [s]: every object becomes a track
/// observation (label and box of its detection, its position, the grid's velocity when its
/// region is dynamic, its cell counts and per-frame motion); objects of confirmed tracks take
/// the track's id, motion, filtered position and, when dynamic, velocity and heading (static
/// and unknown ones zero, as the message says); the others are removed and their detection
/// indices listed in result.tentative. Sets result.tracked.
void trackObjects(Tracker& tracker, double stamp_s, const std::vector<Detection>& detections,
                  FusionResult& result);

/// Intersection over union of two boxes (continuous pixel coordinates), 0 when disjoint or empty.
double boxOverlap(const BoundingBox& a, const BoundingBox& b);

}  // namespace grid_vision_fusion
