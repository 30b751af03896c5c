// The glue between messages, tf and the four cores that the nodelets and the offline
// run_pipeline share: the node-level options of each stage read from the same parameters, how
// a scan's pose becomes the grid filter's input, how the projection gets its camera, ground
// height and camera ← grid transform, how an image reaches the detector, how a detection /
// projected-grid pair becomes objects.
#pragma once

#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>
#include <tf2/buffer_core.h>

#include <Eigen/Geometry>

#include <stdexcept>
#include <string>
#include <vector>

#include "grid_vision_fusion/DetectedObjectArray.h"
#include "grid_vision_fusion/Detection2DArray.h"
#include "grid_vision_fusion/DynamicGrid.h"
#include "grid_vision_fusion/ProjectedGrid.h"
#include "grid_vision_fusion/core/fusion.h"
#include "grid_vision_fusion/core/grid_projection.h"
#include "grid_vision_fusion/core/yolo_detector.h"
#include "grid_vision_fusion/ros/params.h"

namespace grid_vision_fusion
{
// --- dynamic grid ------------------------------------------------------------------------------

/// The dynamic_grid node's own parameters (besides DynamicGridConfig).
struct DynamicGridNodeOptions
{
  std::string fixed_frame = "world";  ///< frame of the grid and of the filter's poses
  bool lazy = true;                   ///< subscribe only while someone listens
  int queue_size = 5;                 ///< clouds waiting for their tf (>= 1)
  double expected_rate = 10.0;        ///< scan rate for the diagnostics [Hz] (> 0)
};

/// DynamicGridNodeOptions from the parameters fixed_frame, lazy, queue_size, expected_rate.
/// @throws std::invalid_argument naming the parameter (wrong type, empty fixed_frame,
/// queue_size < 1, expected_rate <= 0).
DynamicGridNodeOptions dynamicGridNodeOptionsFromParams(const ParamSource& params);

/// The filter's input pose of a scan: fixed frame ← sensor frame at the scan stamp, from tf
/// (no waiting). @throws tf2::TransformException when tf cannot answer.
Eigen::Isometry3d scanPose(const tf2::BufferCore& tf, const std::string& fixed_frame,
                           const std::string& sensor_frame, const ros::Time& stamp);

// --- grid projection ---------------------------------------------------------------------------

/// The grid_projection node's own parameters (besides GridProjectionConfig).
struct GridProjectionNodeOptions
{
  /// Frame whose origin the ground plane is ground_height below (empty: ground_height is the z
  /// of the ground in the grid frame itself).
  std::string ground_frame = "velo_link";
  double ground_height = -1.73;  ///< [m], finite
  double max_grid_age = 0.5;     ///< largest |t_image − t_grid| projected [s] (> 0)
  int image_cache_size = 5;      ///< images kept for the overlay (>= 1)
  bool lazy = true;
};

/// GridProjectionNodeOptions from the parameters ground_frame, ground_height, max_grid_age,
/// image_cache_size, lazy. @throws std::invalid_argument naming the parameter.
GridProjectionNodeOptions gridProjectionNodeOptionsFromParams(const ParamSource& params);

/// z of the ground plane in `grid_frame` at `stamp`: ground_height below/above the origin of
/// ground_frame, transformed by tf (or ground_height itself when ground_frame is empty).
/// @throws tf2::TransformException when tf cannot answer.
double groundZInGridFrame(const tf2::BufferCore& tf, const GridProjectionNodeOptions& options,
                          const std::string& grid_frame, const ros::Time& stamp);

/// Why a camera_info produced no projected grid.
class ProjectionSkipped : public std::runtime_error
{
public:
  using std::runtime_error::runtime_error;
};

/// The projection of `grid` into the camera of `info` as the grid_projection nodelet does it:
/// camera from CameraInfo, grid age check (max_grid_age), camera ← grid transform and ground
/// height from tf at the image stamp, projectGrid(), ProjectedGrid stamped like the image.
/// `grid` must have passed checkDynamicGrid(). `invalid_cells` (when given) receives the count
/// of cells skipped for NaN/Inf values.
/// @throws ProjectionSkipped with the reason (unusable camera_info, grid too old, no tf).
ProjectedGrid::Ptr projectGridIntoCamera(const DynamicGrid& grid, const sensor_msgs::CameraInfo& info,
                                         const tf2::BufferCore& tf, const GridProjectionNodeOptions& options,
                                         const GridProjectionConfig& config,
                                         std::size_t* invalid_cells = nullptr);

// --- detector ----------------------------------------------------------------------------------

/// The detections of a YOLO network in `image` (rgb8, bgr8 or mono8; no copy of the pixels).
/// @throws std::invalid_argument for an unsupported encoding; what detect() throws.
std::vector<Detection> detectInImage(YoloDetector& detector, const sensor_msgs::Image::ConstPtr& image);

// --- fusion ------------------------------------------------------------------------------------

/// A fused detection / projected-grid pair.
struct FusedPair
{
  std::vector<Detection> detections;  ///< the boxes of the Detection2DArray
  FusionResult result;                ///< the fusion core's result
  DetectedObjectArray::Ptr objects;   ///< the message (stamp of the image, grid frame)
};

/// Checks and fuses a pair as the fusion nodelet does: checkProjectedGrid(),
/// checkFusionInputs(), fuse(), objectsToMsg(). @throws std::invalid_argument naming what is
/// wrong with the pair.
FusedPair fusePair(const Detection2DArray& detections, const ProjectedGrid& grid, const FusionConfig& config);

}  // namespace grid_vision_fusion
