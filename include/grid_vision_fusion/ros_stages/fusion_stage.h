// The fusion stage: a Detection2DArray and the ProjectedGrid of the same image in, the fused
// objects (DetectedObjectArray) out. Shared by the fusion nodelet and the offline Pipeline.
#pragma once

#include <vector>

#include "grid_vision_fusion/DetectedObjectArray.h"
#include "grid_vision_fusion/Detection2DArray.h"
#include "grid_vision_fusion/ProjectedGrid.h"
#include "grid_vision_fusion/fusion/fusion.h"
#include "grid_vision_fusion/fusion/tracker.h"
#include "grid_vision_fusion/ros/node_params.h"

namespace grid_vision_fusion
{
/// The most detections one pair may hold. A detector gives tens per image; many more would make
/// the fusion regions and the tracker's assignment (cubic in the count) run for minutes and
/// take gigabytes, so such a pair is refused.
constexpr std::size_t kMaxFusionDetections = 1000;

/// A fused detection / projected-grid pair.
struct FusedPair
{
  std::vector<Detection> detections;  ///< the boxes of the Detection2DArray
  FusionResult result;                ///< the objects as published (tracked when tracking is on)
  DetectedObjectArray::Ptr objects;   ///< the message (stamp of the image, grid frame)
  /// With tracking: why the tracks were dropped before this pair (time going backwards, a gap
  /// above track_max_gap); empty when they were kept.
  std::string tracks_reset;
  /// Boxes without cells left out because the projected grid does not say where the image meets
  /// the ground (no grid_to_image: a producer older than the field); 0 otherwise.
  std::size_t unplaced = 0;
};

/// The fusion with its parameters, and the tracker that carries the objects from pair to pair.
/// Not thread-safe.
class FusionStage
{
public:
  /// @throws std::invalid_argument when `params` is invalid.
  explicit FusionStage(const FusionParams& params);

  /// Checks and fuses a pair: checkProjectedGrid(), checkFusionInputs(), fuse(), the position
  /// (estimateCentres() unless params.fusion.position is kMedian), with tracking the tracker
  /// (every object stays, tentative or confirmed, with its track's id, P(dynamic), motion,
  /// position and velocity), then objectsToMsg(). Pairs must come in stamp order.
  /// @throws std::invalid_argument naming what is wrong with the pair, e.g. more than
  ///         kMaxFusionDetections detections (the tracker is untouched).
  FusedPair fuse(const Detection2DArray& detections, const ProjectedGrid& grid);

  /// Replaces the fusion configuration (dynamic_reconfigure). @throws std::invalid_argument
  /// as FusionConfig::validate(), leaving the configuration unchanged.
  void setConfig(const FusionConfig& config);

  const FusionConfig& config() const { return params_.fusion; }
  const FusionParams& params() const { return params_; }
  /// The tracker (its tracks live as long as the stage).
  const Tracker& tracker() const { return tracker_; }

private:
  FusionParams params_;
  Tracker tracker_;
};

}  // namespace grid_vision_fusion
