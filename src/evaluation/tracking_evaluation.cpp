// The tracking figures of evaluateTracking(): CLEAR MOT, the identity measures, the motion's
// stability and the time to the first dynamic verdict, frame by frame (see TrackingMetrics).
#include <algorithm>
#include <cmath>
#include <map>
#include <set>
#include <stdexcept>
#include <unordered_map>
#include <utility>

#include "grid_vision_fusion/evaluation/evaluation.h"
#include "grid_vision_fusion/fusion/assignment.h"

namespace grid_vision_fusion
{
void TrackingEvaluationConfig::validate() const
{
  if (!(iou_threshold > 0.0 && iou_threshold <= 1.0))
  {
    throw std::invalid_argument("iou_threshold must be in (0, 1], got " + std::to_string(iou_threshold));
  }
  if (!(max_longitudinal_m > 0.0))
  {
    throw std::invalid_argument("max_longitudinal_m must be > 0, got " + std::to_string(max_longitudinal_m));
  }
  if (!(flicker_window_s > 0.0))
  {
    throw std::invalid_argument("flicker_window_s must be > 0, got " + std::to_string(flicker_window_s));
  }
  if (!(latency_speed_mps > 0.0))
  {
    throw std::invalid_argument("latency_speed_mps must be > 0, got " + std::to_string(latency_speed_mps));
  }
}

namespace
{
/// The state of one ground-truth identity while the frames go by.
struct TruthTrackState
{
  bool ever_matched = false;
  bool interrupted = false;         ///< unmatched in a frame since its last match
  std::int64_t last_detection = 0;  ///< detection id of its last match
  std::size_t frames = 0;
  std::size_t matched_frames = 0;
  // Motion stability.
  bool has_motion = false;
  Motion last_motion = Motion::kUnknown;
  Motion last_truth = Motion::kUnknown;
  bool has_change = false;
  double last_change_s = 0.0;
  bool flickered = false;
  // Time to the first dynamic verdict.
  bool moving_seen = false;     ///< matched once while moving at latency_speed_mps or more...
  double moving_since_s = 0.0;  ///< ...at this time
  bool dynamic_seen = false;    ///< reported dynamic at or after moving_since_s
  double latency_s = -1.0;
  std::string label;
};

/// Identities of `objects`: their track_id, or a fresh negative id (below −1) where it is −1.
std::vector<std::int64_t> identities(const std::vector<EvalObject>& objects,
                                     const std::vector<std::size_t>& indices)
{
  std::vector<std::int64_t> ids(objects.size(), -1);
  std::int64_t next_anonymous = -2;
  for (std::size_t i : indices)
  {
    ids[i] = objects[i].track_id >= 0 ? objects[i].track_id : next_anonymous--;
  }
  return ids;
}

/// The inputs of evaluateTracking(), and whether a ground-truth object and a detection qualify
/// for a match.
struct TrackingInput
{
  const std::vector<EvalObject>& ground_truth;
  const std::vector<EvalObject>& detections;
  const TrackingEvaluationConfig& config;

  /// Same label and IoU >= the threshold.
  bool qualifies(std::size_t g, std::size_t d) const
  {
    return ground_truth[g].label == detections[d].label &&
           boxIou(ground_truth[g].box, detections[d].box) >= config.iou_threshold;
  }
};

/// Frame -> objects (ground truth beyond the range limit is ignored later, as difficult) and
/// DontCare regions, frames in name order (10-digit indices: time order); every object's identity.
struct FramedObjects
{
  std::map<std::string, std::vector<std::size_t>> gt_of, det_of;
  DontCareRegions dont_care;
  std::vector<std::int64_t> gt_id, det_id;
  std::set<std::string> frames;
};

FramedObjects framedObjects(const TrackingInput& in)
{
  FramedObjects f;
  std::vector<std::size_t> gt_all, det_all;
  for (std::size_t g = 0; g < in.ground_truth.size(); ++g)
  {
    if (in.ground_truth[g].dont_care)
    {
      f.dont_care[in.ground_truth[g].frame].push_back(in.ground_truth[g].box);
      continue;
    }
    f.gt_of[in.ground_truth[g].frame].push_back(g);
    gt_all.push_back(g);
  }
  for (std::size_t d = 0; d < in.detections.size(); ++d)
  {
    f.det_of[in.detections[d].frame].push_back(d);
    det_all.push_back(d);
  }
  f.gt_id = identities(in.ground_truth, gt_all);
  f.det_id = identities(in.detections, det_all);
  for (const auto& entry : f.gt_of)
  {
    f.frames.insert(entry.first);
  }
  for (const auto& entry : f.det_of)
  {
    f.frames.insert(entry.first);
  }
  return f;
}

/// What the frames add up to for the identities and the per-track figures.
struct TrackingTally
{
  std::map<std::int64_t, TruthTrackState> truth_state;
  std::map<std::pair<std::int64_t, std::int64_t>, std::size_t> co_matched;  // (gt id, det id) -> frames
  std::map<std::int64_t, std::size_t> truth_frames, detection_frames;
};

/// One frame's objects and their correspondences.
struct FrameMatch
{
  std::vector<std::size_t> truth, difficult;  ///< counted, ignored (difficult or beyond the range)
  std::vector<std::size_t> dets;              ///< the frame's detections
  std::vector<std::size_t> det_match;         ///< per detection: index into truth, or kUnassigned
  std::vector<std::size_t> truth_match;       ///< per counted truth: index into dets, or kUnassigned
  std::vector<bool> ignored;                  ///< per detection: neither matched nor counted
};

/// Keeps the previous correspondences that still qualify.
void keepPreviousMatches(const TrackingInput& in, const FramedObjects& f, TrackingTally& tally,
                         FrameMatch& fm)
{
  for (std::size_t i = 0; i < fm.truth.size(); ++i)
  {
    const TruthTrackState& state = tally.truth_state[f.gt_id[fm.truth[i]]];
    if (!state.ever_matched)
    {
      continue;
    }
    for (std::size_t j = 0; j < fm.dets.size(); ++j)
    {
      if (fm.det_match[j] == kUnassigned && f.det_id[fm.dets[j]] == state.last_detection &&
          in.qualifies(fm.truth[i], fm.dets[j]))
      {
        fm.det_match[j] = i;
        fm.truth_match[i] = j;
        break;
      }
    }
  }
}

/// The rest by the Hungarian method on 1 − IoU.
void assignTheRest(const TrackingInput& in, FrameMatch& fm)
{
  std::vector<std::size_t> free_truth, free_dets;
  for (std::size_t i = 0; i < fm.truth.size(); ++i)
  {
    if (fm.truth_match[i] == kUnassigned)
    {
      free_truth.push_back(i);
    }
  }
  for (std::size_t j = 0; j < fm.dets.size(); ++j)
  {
    if (fm.det_match[j] == kUnassigned)
    {
      free_dets.push_back(j);
    }
  }
  CostMatrix cost(free_truth.size(), free_dets.size());
  for (std::size_t a = 0; a < free_truth.size(); ++a)
  {
    for (std::size_t b = 0; b < free_dets.size(); ++b)
    {
      const std::size_t g = fm.truth[free_truth[a]];
      const std::size_t d = fm.dets[free_dets[b]];
      if (in.qualifies(g, d))
      {
        cost.at(a, b) = 1.0 - boxIou(in.ground_truth[g].box, in.detections[d].box);
      }
    }
  }
  const std::vector<std::size_t> assigned = solveAssignment(cost);
  for (std::size_t a = 0; a < free_truth.size(); ++a)
  {
    if (assigned[a] != kUnassigned)
    {
      fm.truth_match[free_truth[a]] = free_dets[assigned[a]];
      fm.det_match[free_dets[assigned[a]]] = free_truth[a];
    }
  }
}

/// Unmatched detections that match ignored ground truth, lie beyond the range limit or in a
/// DontCare region are ignored; the other unmatched ones are false positives. Every detection
/// not ignored counts a frame of its identity.
void ignoreUnmatched(const TrackingInput& in, const FramedObjects& f, const std::string& frame,
                     TrackingTally& tally, FrameMatch& fm, TrackingMetrics& m)
{
  fm.ignored.assign(fm.dets.size(), false);
  for (std::size_t j = 0; j < fm.dets.size(); ++j)
  {
    if (fm.det_match[j] != kUnassigned)
    {
      continue;
    }
    const EvalObject& det = in.detections[fm.dets[j]];
    fm.ignored[j] = !inRange(det, in.config.max_longitudinal_m) ||
                    std::any_of(fm.difficult.begin(), fm.difficult.end(),
                                [&](std::size_t g) { return in.qualifies(g, fm.dets[j]); }) ||
                    inDontCare(f.dont_care, frame, det.box, in.config.iou_threshold);
    if (!fm.ignored[j])
    {
      ++m.false_positives;
    }
  }
  for (std::size_t j = 0; j < fm.dets.size(); ++j)
  {
    if (!fm.ignored[j])
    {
      ++tally.detection_frames[f.det_id[fm.dets[j]]];
    }
  }
}

/// The time to the first dynamic verdict: from the first match while the truth `t` moves at
/// latency_speed_mps or more to the first match reported dynamic.
void updateLatency(TruthTrackState& state, const EvalObject& t, const EvalObject& det,
                   const TrackingEvaluationConfig& config)
{
  if (!state.moving_seen && t.has_state && std::hypot(t.vx, t.vy) >= config.latency_speed_mps)
  {
    state.moving_seen = true;
    state.moving_since_s = det.time_s;
    state.label = t.label;
  }
  if (state.moving_seen && !state.dynamic_seen && det.motion == Motion::kDynamic)
  {
    state.dynamic_seen = true;
    state.latency_s = det.time_s - state.moving_since_s;
  }
}

/// Reported motion changes and flickers while the truth motion stays the same.
void updateMotionStability(TruthTrackState& state, Motion truth_motion, const EvalObject& det,
                           const TrackingEvaluationConfig& config, TrackingMetrics& m)
{
  if (state.has_motion && truth_motion == state.last_truth && truth_motion != Motion::kUnknown)
  {
    if (det.motion != state.last_motion)
    {
      ++m.motion_changes;
      if (state.has_change && det.time_s - state.last_change_s < config.flicker_window_s)
      {
        ++m.motion_flickers;
        state.flickered = true;
      }
      state.has_change = true;
      state.last_change_s = det.time_s;
    }
  }
  else
  {
    state.has_change = false;  // the truth changed: a new constant stretch
  }
  state.has_motion = true;
  state.last_motion = det.motion;
  state.last_truth = truth_motion;
}

/// Per counted ground-truth object of the frame: the CLEAR MOT counts, the co-matched frames of
/// the identity measures, the latency and the motion's stability.
void countTruth(const TrackingInput& in, const FramedObjects& f, TrackingTally& tally, const FrameMatch& fm,
                TrackingMetrics& m)
{
  for (std::size_t i = 0; i < fm.truth.size(); ++i)
  {
    const std::size_t g = fm.truth[i];
    const std::int64_t id = f.gt_id[g];
    TruthTrackState& state = tally.truth_state[id];
    ++m.ground_truth;
    ++state.frames;
    ++tally.truth_frames[id];
    for (std::size_t j = 0; j < fm.dets.size(); ++j)
    {
      if (!fm.ignored[j] && in.qualifies(g, fm.dets[j]))
      {
        ++tally.co_matched[{id, f.det_id[fm.dets[j]]}];
      }
    }
    if (fm.truth_match[i] == kUnassigned)
    {
      ++m.misses;
      state.interrupted = state.ever_matched;
      continue;
    }
    const EvalObject& det = in.detections[fm.dets[fm.truth_match[i]]];
    const std::int64_t matched_id = f.det_id[fm.dets[fm.truth_match[i]]];
    ++m.matches;
    ++state.matched_frames;
    if (state.ever_matched && state.last_detection != matched_id)
    {
      ++m.id_switches;
    }
    if (state.interrupted)
    {
      ++m.fragmentations;
    }
    state.ever_matched = true;
    state.interrupted = false;
    state.last_detection = matched_id;
    updateLatency(state, in.ground_truth[g], det, in.config);
    updateMotionStability(state, in.ground_truth[g].motion, det, in.config, m);
  }
}

/// One frame: its objects matched (previous correspondences first, then the Hungarian method)
/// and counted.
void evaluateFrame(const TrackingInput& in, FramedObjects& f, const std::string& frame, TrackingTally& tally,
                   TrackingMetrics& m)
{
  FrameMatch fm;
  for (std::size_t g : f.gt_of[frame])
  {
    const bool ignored =
        in.ground_truth[g].difficult || !inRange(in.ground_truth[g], in.config.max_longitudinal_m);
    (ignored ? fm.difficult : fm.truth).push_back(g);
  }
  fm.dets = f.det_of[frame];
  fm.det_match.assign(fm.dets.size(), kUnassigned);
  fm.truth_match.assign(fm.truth.size(), kUnassigned);
  keepPreviousMatches(in, f, tally, fm);
  assignTheRest(in, fm);
  ignoreUnmatched(in, f, frame, tally, fm, m);
  countTruth(in, f, tally, fm, m);
}

/// The per-track figures (mostly tracked and lost, flickering tracks, latencies), MOTA and the
/// id switches per 100 matches.
void summariseTracks(const TrackingTally& tally, TrackingMetrics& m)
{
  for (const auto& [id, state] : tally.truth_state)
  {
    (void)id;
    if (state.frames == 0)
    {
      continue;
    }
    ++m.truth_tracks;
    const double share = static_cast<double>(state.matched_frames) / static_cast<double>(state.frames);
    m.mostly_tracked += share >= 0.8 ? 1 : 0;
    m.mostly_lost += share < 0.2 ? 1 : 0;
    m.flickering_tracks += state.flickered ? 1 : 0;
    if (state.moving_seen)
    {
      m.dynamic_latency.push_back({state.label, id, state.latency_s});
    }
  }
  if (m.ground_truth > 0)
  {
    m.mota = 1.0 - static_cast<double>(m.misses + m.false_positives + m.id_switches) /
                       static_cast<double>(m.ground_truth);
  }
  if (m.matches > 0)
  {
    m.id_switches_per_100 = 100.0 * static_cast<double>(m.id_switches) / static_cast<double>(m.matches);
  }
}

/// Identity: ground-truth identities (rows) to detection ids (columns) or to nothing (one dummy
/// column per row), maximising the co-matched frames: cost = largest − co-matched.
void identityMeasures(const TrackingTally& tally, TrackingMetrics& m)
{
  const auto& co_matched = tally.co_matched;
  std::vector<std::int64_t> truth_ids, det_ids;
  for (const auto& entry : tally.truth_frames)
  {
    truth_ids.push_back(entry.first);
  }
  for (const auto& entry : tally.detection_frames)
  {
    det_ids.push_back(entry.first);
  }
  std::unordered_map<std::int64_t, std::size_t> det_column;
  for (std::size_t c = 0; c < det_ids.size(); ++c)
  {
    det_column[det_ids[c]] = c;
  }
  double largest = 0.0;
  for (const auto& entry : co_matched)
  {
    largest = std::max(largest, static_cast<double>(entry.second));
  }
  CostMatrix identity(truth_ids.size(), det_ids.size() + truth_ids.size());
  std::fill(identity.cost.begin(), identity.cost.end(), largest);
  std::unordered_map<std::int64_t, std::size_t> truth_row;
  for (std::size_t r = 0; r < truth_ids.size(); ++r)
  {
    truth_row[truth_ids[r]] = r;
  }
  for (const auto& [pair, frames_together] : co_matched)
  {
    identity.at(truth_row.at(pair.first), det_column.at(pair.second)) =
        largest - static_cast<double>(frames_together);
  }
  const std::vector<std::size_t> identity_match = solveAssignment(identity);
  for (std::size_t r = 0; r < truth_ids.size(); ++r)
  {
    const std::size_t c = identity_match[r];
    if (c != kUnassigned && c < det_ids.size())
    {
      const auto it = co_matched.find({truth_ids[r], det_ids[c]});
      m.idtp += it == co_matched.end() ? 0 : it->second;
    }
  }
  std::size_t truth_total = 0, detection_total = 0;
  for (const auto& entry : tally.truth_frames)
  {
    truth_total += entry.second;
  }
  for (const auto& entry : tally.detection_frames)
  {
    detection_total += entry.second;
  }
  m.idfn = truth_total - m.idtp;
  m.idfp = detection_total - m.idtp;
  if (m.idtp > 0)
  {
    m.idp = static_cast<double>(m.idtp) / static_cast<double>(m.idtp + m.idfp);
    m.idr = static_cast<double>(m.idtp) / static_cast<double>(m.idtp + m.idfn);
    m.idf1 = 2.0 * static_cast<double>(m.idtp) / static_cast<double>(2 * m.idtp + m.idfp + m.idfn);
  }
}
}  // namespace

TrackingMetrics evaluateTracking(const std::vector<EvalObject>& ground_truth,
                                 const std::vector<EvalObject>& detections,
                                 const TrackingEvaluationConfig& config)
{
  config.validate();
  TrackingMetrics m;
  const TrackingInput in{ground_truth, detections, config};
  FramedObjects objects = framedObjects(in);
  TrackingTally tally;
  for (const std::string& frame : objects.frames)
  {
    evaluateFrame(in, objects, frame, tally, m);
  }
  summariseTracks(tally, m);
  identityMeasures(tally, m);
  return m;
}

}  // namespace grid_vision_fusion
