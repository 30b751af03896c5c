// Multi-object tracking of the fused objects: objects that persist from image to image with a
// stable id, and a motion model per track (MotionModel: a stationary and a constant-velocity
// model in the fixed (grid) frame) that gives each object its filtered state and P(dynamic).
//
// Per image (Tracker::update): every track is predicted to the image stamp; tracks and fused
// objects are associated by an optimal assignment (solveAssignment()) of the pairs that pass the
// gate (same label, and the object within gate_sigma of the track's predicted position, or its
// box overlapping the track's last box by min_iou or more); the cost of a pair is its squared
// Mahalanobis distance over gate_sigma² plus iou_weight · (1 − IoU). A matched track's motion model
// is updated with the object's centre, or, when the object passed the gate by its box alone (a jump
// of the centre estimate), restarted there keeping its velocity (at the prior's uncertainty) and
// P(dynamic) (MotionModel::restartAt()), except at the track's second object (its first step: a
// track seen once has no estimate to jump from); the centre of a box cut by the image's left or
// right edge is measured across the object's length only (its visible part slides along the length
// as the object leaves or enters the view), in the gate too. A new track's motion model takes its
// label's prior speed (TrackerConfig::motionFor()). An object left over starts a tentative track,
// which becomes confirmed after min_hits hits; a track, tentative or confirmed, is dropped after
// more than max_misses consecutive misses (a trained detector misses a small object in one image
// and finds it in the next: its track keeps what it knew). Every matched object is reported,
// tentative ones too.
#pragma once

#include <cstddef>
#include <cstdint>
#include <deque>
#include <limits>
#include <map>
#include <string>
#include <vector>

#include "grid_vision_fusion/fusion/motion_model.h"
#include "grid_vision_fusion/types.h"

namespace grid_vision_fusion
{
/// Parameters of the tracker.
struct TrackerConfig
{
  int min_hits = 2;    ///< hits (images with a matched object) that confirm a track, >= 1
  int max_misses = 5;  ///< a track is dropped after more consecutive misses, >= 0
  /// Gate on the predicted position: squared Mahalanobis distance <= gate_sigma² [σ], > 0.
  double gate_sigma = 3.0;
  /// Boxes overlapping the track's last box by this IoU or more pass the gate whatever their
  /// position, (0, 1]; a second cue where the position estimate jumps (an object partly hidden).
  double min_iou = 0.3;
  double iou_weight = 1.0;      ///< weight of (1 − IoU) in the association cost, >= 0
  double position_sigma = 0.5;  ///< noise of a position in the association gate [m], > 0
  double max_gap = 1.0;         ///< more time between two images [s], or time going back, resets the tracks
  /// Gain of the track's box filter, (0, 1]: the weight of a new box's edges against their
  /// prediction (an alpha-beta filter per edge with beta = gain² / (2 − gain)); the fusion band
  /// and cluster of a tracked object hang on the filtered box (priors()). 1: the detector's box.
  double box_gain = 0.5;
  /// Labels a detector confuses with each other, label → group name: a track takes objects of
  /// every label of its group and reports the label its objects had most often (score-weighted),
  /// whose footprint its centre takes (priors()). A label not in the map is a group of its own;
  /// empty: only the same label is associated. The default groups car, van and truck.
  std::map<std::string, std::string> label_groups{
      {"car", "vehicle"}, {"van", "vehicle"}, {"truck", "vehicle"}};
  /// The motion model of every track: the whole motion verdict.
  MotionModelConfig motion;
  /// The motion model's prior speed (MotionModelConfig::speed_sigma) for the labels whose
  /// objects move at other speeds, label → σ [m/s], each > 0: a pedestrian walks at about
  /// 1.4 m/s, where a vehicle drives at anything up to 15 m/s. Under a prior as wide as a
  /// vehicle's, a walking pedestrian's first steps are explained as well by standing as by
  /// moving (doc/nodelets/fusion.md, "Motion model").
  std::map<std::string, double> class_speed_sigmas{{"pedestrian", 1.5}};

  /// @throws std::invalid_argument naming the first bad field (as the ranges above).
  void validate() const;
  /// `motion` with speed_sigma taken from class_speed_sigmas for `label` (when listed): the
  /// motion model of a track of that label.
  MotionModelConfig motionFor(const std::string& label) const;
};

/// One fused object of an image, as the tracker sees it.
struct TrackObservation
{
  std::string label;           ///< the detector's class; only tracks of its label group are associated
  double score = 1.0;          ///< the detector's confidence, the weight of the label's vote
  std::uint32_t class_id = 0;  ///< the detector's class index of the label
  BoundingBox box;             ///< the detector box [px]
  double x = 0.0;              ///< observed centre [m], fixed frame
  double y = 0.0;
  /// The box is cut by the image's left or right edge: its centre follows the visible part, which
  /// slides along the object as it leaves or enters the view, by up to the object's `length` [m]
  /// (CentreEstimate::length; 0: not known). The outline fitted to a short visible part says
  /// little of the object's axes, so the slide may go any way.
  bool truncated = false;
  double length = 0.0;
  /// The cells of the object's cluster [m], fixed frame: what the track expects to continue in
  /// the next image (priors()).
  std::vector<Eigen::Vector2d> cells;
  /// The cells of the cluster that the lidar hit in the grid's scan [m], fixed frame, on the
  /// grid's lattice of step cell_size [m] (0: not known): registered against the track's earlier
  /// hits (scan_registration.h).
  std::vector<Eigen::Vector2d> hits;
  double cell_size = 0.0;
  GridMotionEvidence grid;  ///< what the grid says about the object's motion
  /// Whether grid cells support the object (its fusion band holds some): else x, y come from its
  /// box (NaN when not even that) and say too little to move the track's motion model, which only
  /// predicts; the track keeps the object (its box, label, hits), and its estimate says so.
  bool supported = true;
};

/// What a detection's track expects of it in an image (Tracker::priors()); all empty for a
/// detection that no track expects.
struct TrackPrior
{
  /// The cells of the track's cluster in its last image, moved on by its velocity: fuse()
  /// prefers the cluster that continues them (objectCluster()).
  std::vector<Eigen::Vector2d> cells;
  /// The detection's box filtered with the track's boxes: what the fusion band hangs on. A real
  /// detector's box edges jitter by a few pixels from image to image (doc/detector_noise.md),
  /// and the band's cells and the cluster's choice with them.
  bool has_box = false;
  BoundingBox box;
  /// The label the track's objects had most often (score-weighted): whose footprint completes
  /// the centre, where a detector calls the same van "car" in one image and "van" in the next.
  std::string label;
};

/// What the tracker says about one observation of the image.
struct TrackEstimate
{
  bool confirmed = false;            ///< the track has min_hits hits (else tentative)
  std::uint32_t id = 0;              ///< track id, unique over the tracker's life, from 1
  std::string label;                 ///< the label its objects had most often (score-weighted)...
  std::uint32_t class_id = 0;        ///< ...and that label's detector class index
  Motion motion = Motion::kUnknown;  ///< the verdict: dynamic when p_dynamic > 0.5, static below
  double p_dynamic = 0.5;            ///< P(dynamic), [0, 1]
  double x = 0.0;                    ///< filtered position [m]
  double y = 0.0;
  double vx = 0.0;  ///< the constant-velocity model's velocity [m/s]: the velocity should it move
  double vy = 0.0;
  /// Whether the track has a position of its own: it has had an observation with cells. Without,
  /// x, y, p_dynamic are the observation's box position and 0.5.
  bool located = false;
};

/// "Not known" for a speed or a position: NaN.
constexpr double kNotKnown = std::numeric_limits<double>::quiet_NaN();

/// The tracker. Deterministic; not thread-safe.
class Tracker
{
public:
  /// @throws std::invalid_argument when `config` is invalid.
  explicit Tracker(const TrackerConfig& config = TrackerConfig());

  /// Processes the observations of the image at `stamp_s` [s]: one estimate per observation,
  /// in the same order. Stamps must increase; where resetReason(stamp_s) gives a reason, every
  /// track is dropped first (ids keep counting up).
  /// `scene_hits` are all the cells the lidar hit in the image's scan within the camera's view
  /// [m], fixed frame, on the observations' lattice: an object is hit before it is detected (or
  /// while its detections are missed), so a new track registers its first hits against those of
  /// the scans before around them, from its first image, as a track does its own.
  /// `camera`: the camera's position in the fixed frame at `stamp_s` [m] (NaN: not known), whose
  /// speed between images tells how fast the image edge sweeps along what it cuts (cutNoise()).
  std::vector<TrackEstimate> update(double stamp_s, const std::vector<TrackObservation>& observations,
                                    std::vector<Eigen::Vector2d> scene_hits = {},
                                    const Eigen::Vector2d& camera = Eigen::Vector2d::Constant(kNotKnown));

  /// For each detection of an image at `stamp_s` [s], what the track of its label group whose
  /// last box overlaps the detection's box most (by min_iou or more) expects of it: its cells
  /// moved on by the track's velocity to `stamp_s`, the detection's box filtered with the
  /// track's, the track's label. Empty when no track qualifies. For fuse() and
  /// estimateCentres(); the tracks are not changed (update() filters the box of the observation
  /// it associates with a track the same way).
  std::vector<TrackPrior> priors(double stamp_s, const std::vector<Detection>& detections) const;

  /// Replaces the configuration; the tracks are kept. @throws std::invalid_argument as the
  /// constructor, leaving the configuration unchanged.
  void setConfig(const TrackerConfig& config);
  const TrackerConfig& config() const { return config_; }

  /// Why update() at `stamp_s` [s] starts over (a stamp earlier than the last one: a bag loop;
  /// or later by more than max_gap), empty when it goes on.
  std::string resetReason(double stamp_s) const;
  /// Drops every track (ids keep counting up).
  void reset();
  /// Tracks alive (tentative and confirmed).
  std::size_t size() const { return tracks_.size(); }

private:
  /// Alpha-beta filter of a box's four edges (x_min, y_min, x_max, y_max) [px, px/s].
  struct BoxFilter
  {
    Eigen::Vector4d edges = Eigen::Vector4d::Zero();
    Eigen::Vector4d rates = Eigen::Vector4d::Zero();
    bool has_rates = false;
    BoundingBox box() const;
    /// A filter that starts at `box`, without rates.
    static BoxFilter at(const BoundingBox& box);
  };

  /// The lidar hits of a track's object in one image.
  struct ObservedHits
  {
    double stamp = 0.0;  ///< [s]
    std::vector<Eigen::Vector2d> cells;
  };

  struct Track
  {
    std::uint32_t id = 0;
    std::string group;                                   ///< label group of its objects
    std::map<std::string, double> label_votes;           ///< label → sum of its objects' scores
    std::map<std::string, std::uint32_t> label_classes;  ///< label → detector class index
    MotionModel motion;
    MotionEvidence evidence;             ///< of its object in the latest image besides the centre
    BoundingBox box;                     ///< the detector's box in its last image
    BoxFilter box_filter;                ///< the filtered box
    std::vector<Eigen::Vector2d> cells;  ///< of its object's cluster in its last image
    /// Its objects' lidar hits of the last images, oldest first, within
    /// kRegistrationSpan of the latest.
    std::deque<ObservedHits> recent_hits;
    double last_seen = 0.0;  ///< stamp of its last image with an object [s]
    int hits = 0;
    int misses = 0;
    bool confirmed = false;
    double first_stamp = 0.0;  ///< stamp of its first image [s]
    bool located = false;      ///< its motion model has started: it has had an observation with cells
    int centres = 0;           ///< observations with cells since it was located
  };

  /// For every track, the observation it is paired with (kUnassigned: none): the gated pairs'
  /// optimal assignment (an observation without cells is admitted by its box alone).
  std::vector<std::size_t> associate(const std::vector<TrackObservation>& observations) const;
  /// A matched track takes its observation: the centre (or a restart there), then the grid's
  /// evidence, then the registration of its hits; an observation without cells only its box and
  /// label.
  void updateTrack(Track& track, const TrackObservation& observation) const;
  /// The motion model of a track without a position of its own starts at `observation` (which
  /// has cells), with the hits of the scans before.
  void locate(Track& track, const TrackObservation& observation) const;
  /// A located track takes an observation with cells into its motion model.
  void updateMotion(Track& track, const TrackObservation& observation) const;
  /// The registration of the observation's lidar hits against the track's oldest hits within
  /// kRegistrationSpan (the track's evidence of this image); then the observation's hits join the
  /// track's.
  void registerHits(Track& track, const TrackObservation& observation) const;
  /// The hits of the earlier scans (scene_hits_) that the new track's first observation may have
  /// moved from: those within registrationReach() of its hits under its motion model `motion`.
  std::deque<ObservedHits> hitsBefore(const TrackObservation& observation, const MotionModel& motion) const;
  /// A tentative track for an observation left over.
  Track newTrack(const TrackObservation& observation, double stamp_s);
  TrackEstimate estimateOf(const Track& track) const;
  /// The track's box filter after taking `box` at `stamp_s`.
  BoxFilter filteredBox(const Track& track, const BoundingBox& box, double stamp_s) const;
  /// The label the track's objects had most often (score-weighted).
  static const std::string& majorityLabel(const Track& track);
  /// The label group of `label` (label_groups, or the label itself).
  const std::string& groupOf(const std::string& label) const;
  /// Squared Mahalanobis distance of the observation from the track's predicted position, with
  /// the association noise position_sigma and, for a box cut by the image edge, its centre's
  /// offset along the object's length: the association gate and the update's gate.
  double positionDistance2(const Track& track, const TrackObservation& observation) const;
  /// What a box cut by the image edge adds to its centre's noise [m²]: the centre is the visible
  /// part's, off by up to half the object's length, in a direction the outline of a short visible
  /// part does not tell, and the edge sweeps along a standing object as fast as the camera moves:
  /// offset min(half the length, camera speed × kRegistrationSpan) in every direction (half the length
  /// when the camera's speed is not known). Zero for a box that is not cut.
  Eigen::Matrix2d cutNoise(const TrackObservation& observation) const;

  TrackerConfig config_;
  std::vector<Track> tracks_;
  /// The scene's hits of the last images, oldest first, within kRegistrationSpan of the latest.
  std::deque<ObservedHits> scene_hits_;
  std::uint32_t next_id_ = 1;
  bool has_stamp_ = false;
  double last_stamp_ = 0.0;
  Eigen::Vector2d last_camera_ = Eigen::Vector2d::Constant(kNotKnown);  ///< at last_stamp_ [m]
  double camera_speed_ = kNotKnown;  ///< between the last two images [m/s]; NaN: not known
};

/// Intersection over union of two boxes (continuous pixel coordinates), 0 when disjoint or empty.
double boxOverlap(const BoundingBox& a, const BoundingBox& b);

}  // namespace grid_vision_fusion
