#include "grid_vision_fusion/fusion/object_tracking.h"

#include <algorithm>
#include <cmath>
#include <utility>

#include "grid_vision_fusion/fusion/model_constants.h"

namespace grid_vision_fusion
{
namespace
{
/// Whether the lidar hit the cell of point `i` in the grid's scan (every point, where the view does
/// not say).
bool isHit(const ProjectedPointsView& points, std::size_t i)
{
  return points.scans_since_hit == nullptr || points.scans_since_hit[i] == 0;
}

}  // namespace

void trackObjects(Tracker& tracker, double stamp_s, const std::vector<Detection>& detections,
                  std::uint32_t image_width, const ProjectedPointsView& points, FusionResult& result,
                  const Eigen::Vector2d& camera)
{
  std::vector<TrackObservation> observations;
  observations.reserve(result.objects.size());
  const float margin = std::max(kTruncationMarginPx, kTruncationMargin * static_cast<float>(image_width));
  const float right_edge = static_cast<float>(image_width) - margin;
  for (const FusedObject& object : result.objects)
  {
    const Detection& detection = detections.at(object.detection_index);
    TrackObservation o;
    o.label = detection.label;
    o.score = detection.score;
    o.class_id = detection.class_id;
    o.box = detection.box;
    o.x = object.x;
    o.y = object.y;
    o.truncated = detection.box.x_min <= margin || detection.box.x_max >= right_edge;
    o.length = object.length;
    o.grid = object.grid;
    o.supported = object.support == ObjectSupport::kCells;
    o.cells.reserve(object.cluster.size());
    for (std::uint32_t i : object.cluster)
    {
      o.cells.emplace_back(points.x[i], points.y[i]);
      if (isHit(points, i))
      {
        o.hits.emplace_back(points.x[i], points.y[i]);
      }
    }
    o.cell_size = points.resolution;
    observations.push_back(std::move(o));
  }
  std::vector<Eigen::Vector2d> scene_hits;
  scene_hits.reserve(points.size);
  for (std::size_t i = 0; i < points.size; ++i)
  {
    if (isHit(points, i))
    {
      scene_hits.emplace_back(points.x[i], points.y[i]);
    }
  }
  const std::vector<TrackEstimate> estimates =
      tracker.update(stamp_s, observations, std::move(scene_hits), camera);
  for (std::size_t i = 0; i < result.objects.size(); ++i)
  {
    FusedObject& object = result.objects[i];
    const TrackEstimate& track = estimates[i];
    object.id = track.id;
    object.label = track.label;
    object.class_id = track.class_id;
    object.track_state = track.confirmed ? TrackState::kConfirmed : TrackState::kTentative;
    if (object.support != ObjectSupport::kCells)
    {
      // No cell says anything about its motion in this image: its track's prediction, or its box.
      object.support = track.located ? ObjectSupport::kTrack : ObjectSupport::kBox;
      object.p_dynamic = track.located ? track.p_dynamic : 0.5;
      object.x = track.located ? track.x : object.x;
      object.y = track.located ? track.y : object.y;
      continue;
    }
    object.p_dynamic = track.p_dynamic;
    object.motion = track.motion;
    object.x = track.x;
    object.y = track.y;
    const bool dynamic = track.motion == Motion::kDynamic;
    object.vx = dynamic ? track.vx : 0.0;
    object.vy = dynamic ? track.vy : 0.0;
    object.heading = dynamic ? std::atan2(track.vy, track.vx) : 0.0;
  }
  result.tracked = true;
}

}  // namespace grid_vision_fusion
