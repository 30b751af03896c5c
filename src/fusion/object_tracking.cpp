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
                  const Eigen::Vector2d& camera, PositionSource position)
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
    const Eigen::Vector2d at = object.position(position);
    o.x = at.x();
    o.y = at.y();
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
  result.reports.clear();
  result.reports.reserve(result.objects.size());
  for (std::size_t i = 0; i < result.objects.size(); ++i)
  {
    const FusedObject& object = result.objects[i];
    const TrackEstimate& track = estimates[i];
    ReportedObject report;
    report.id = track.id;
    report.label = track.label;
    report.class_id = track.class_id;
    report.track_state = track.confirmed ? TrackState::kConfirmed : TrackState::kTentative;
    if (object.support != ObjectSupport::kCells)
    {
      // No cell says anything about its motion in this image: its track's prediction, or its box.
      report.support = track.located ? ObjectSupport::kTrack : ObjectSupport::kBox;
      report.p_dynamic = track.located ? track.p_dynamic : 0.5;
      report.x = track.located ? track.x : observations[i].x;
      report.y = track.located ? track.y : observations[i].y;
      result.reports.push_back(std::move(report));
      continue;
    }
    report.support = ObjectSupport::kCells;
    report.p_dynamic = track.p_dynamic;
    report.motion = track.motion;
    report.x = track.x;
    report.y = track.y;
    const bool dynamic = track.motion == Motion::kDynamic;
    report.vx = dynamic ? track.vx : 0.0;
    report.vy = dynamic ? track.vy : 0.0;
    report.heading = dynamic ? std::atan2(track.vy, track.vx) : 0.0;
    result.reports.push_back(std::move(report));
  }
  result.tracked = true;
}

}  // namespace grid_vision_fusion
