#include "grid_vision_fusion/ros_stages/fusion_stage.h"

#include <algorithm>
#include <stdexcept>

#include "grid_vision_fusion/fusion/object_tracking.h"
#include "grid_vision_fusion/ros/fusion_conversions.h"

namespace grid_vision_fusion
{
FusionStage::FusionStage(const FusionParams& params) : params_(params), tracker_(params.tracker)
{
  params_.fusion.validate();
}

void FusionStage::setConfig(const FusionConfig& config)
{
  config.validate();
  params_.fusion = config;
}

FusedPair FusionStage::fuse(const Detection2DArray& detections, const ProjectedGrid& grid)
{
  const std::string grid_error = checkProjectedGrid(grid);
  if (!grid_error.empty())
  {
    throw std::invalid_argument("projected grid: " + grid_error);
  }
  if (detections.detections.size() > kMaxFusionDetections)
  {
    throw std::invalid_argument(std::to_string(detections.detections.size()) + " detections, more than the " +
                                std::to_string(kMaxFusionDetections) + " a pair may hold");
  }
  FusedPair pair;
  pair.detections = detectionsFromMsg(detections);
  const std::string input_error = checkFusionInputs(
      pair.detections, detections.image_width, detections.image_height, grid.image_width, grid.image_height);
  if (!input_error.empty())
  {
    throw std::invalid_argument(input_error);
  }
  const ProjectedPointsView points = viewOf(grid);
  const double stamp = detections.header.stamp.toSec();
  // A tracked object's band hangs on its filtered box, and its centre takes its track's label's
  // footprint; the messages keep the detector's boxes and the track's label.
  std::vector<Detection> fused = pair.detections;
  std::vector<std::vector<Eigen::Vector2d>> expected;
  if (params_.tracking)
  {
    std::vector<TrackPrior> priors = tracker_.priors(stamp, pair.detections);
    for (std::size_t d = 0; d < priors.size(); ++d)
    {
      if (priors[d].has_box)
      {
        // A filtered edge may be extrapolated past the image.
        fused[d].box = priors[d].box.clippedTo(detections.image_width, detections.image_height);
        fused[d].label = priors[d].label;
      }
      expected.push_back(std::move(priors[d].cells));
    }
  }
  pair.result = grid_vision_fusion::fuse(fused, points, params_.fusion, expected);
  if (params_.fusion.position == PositionSource::kCentre)
  {
    estimateCentres(pair.result, fused, points, grid.camera_position.x, grid.camera_position.y,
                    params_.fusion.centre);
  }
  const ImageGround ground = imageGroundOf(grid);
  if (ground.valid())
  {
    placeOnGround(pair.result, fused, ground, params_.fusion.centre.footprints);
  }
  else
  {
    auto& objects = pair.result.objects;
    const auto unplaced =
        std::remove_if(objects.begin(), objects.end(),
                       [](const FusedObject& object) { return object.support != ObjectSupport::kCells; });
    pair.unplaced = static_cast<std::size_t>(objects.end() - unplaced);
    objects.erase(unplaced, objects.end());
  }
  if (params_.tracking)
  {
    pair.tracks_reset = tracker_.resetReason(stamp);
    trackObjects(tracker_, stamp, pair.detections, detections.image_width, points, pair.result,
                 Eigen::Vector2d(grid.camera_position.x, grid.camera_position.y), params_.fusion.position);
  }
  else
  {
    reportPerFrame(pair.result, pair.detections, params_.fusion.position);
  }
  pair.objects = objectsToMsg(detections.header, grid.grid_frame_id, pair.detections, pair.result);
  return pair;
}

}  // namespace grid_vision_fusion
