// Reading the detections of a run (a bag of grid_vision_fusion/DetectedObjectArray) for the
// evaluation: every message is matched to the drive frame with the nearest image time stamp and
// its objects become EvalObjects.
//
// Frames: positions and velocities are taken in the ground truth's world frame (the `world` frame
// of bags made by kitti_to_bag: the IMU frame of the first OXTS record). A message in that frame
// is taken as it is; one in the odometry frame (kitti_to_bag's `odom`, where the grid lives by
// default) is moved into it with the drive's odometry (KittiDrive::worldFromOdom(), the same
// dead reckoning as kitti_to_bag's). No tf lookup is made; messages in another frame are taken
// as they are and counted (DetectionBagStats::other_frame) so that the tool can warn.
#pragma once

#include <Eigen/Geometry>

#include <cstddef>
#include <functional>
#include <set>
#include <string>
#include <vector>

#include <grid_vision_fusion/DetectedObjectArray.h>

#include "grid_vision_fusion/evaluation/evaluation.h"
#include "grid_vision_fusion/evaluation/kitti_ground_truth.h"

namespace grid_vision_fusion
{
/// Parameters of readDetectionBag().
struct DetectionBagConfig
{
  std::string topic = "/objects";     ///< DetectedObjectArray topic in the bag
  double stamp_tolerance_s = 0.05;    ///< largest |header stamp − image stamp| of a match [s], > 0
  std::string world_frame = "world";  ///< header.frame_id of the ground truth's frame
  std::string odom_frame = "odom";    ///< header.frame_id moved into it by the drive's odometry

  /// @throws std::invalid_argument naming the bad field.
  void validate() const;
};

/// What readDetectionBag() saw.
struct DetectionBagStats
{
  std::size_t messages = 0;         ///< messages on the topic
  std::size_t unmatched = 0;        ///< messages with no frame within the tolerance (left out)
  std::size_t duplicates = 0;       ///< messages of a frame that had one already (the nearer kept)
  std::size_t other_frame = 0;      ///< messages whose header.frame_id is neither world_frame nor odom_frame
  std::size_t invalid_objects = 0;  ///< objects with a non-finite box, score or position (left out)
  std::size_t dropped_labels = 0;   ///< objects whose label the class map drops
};

/// The detections of a bag.
struct DetectionBagResult
{
  std::vector<EvalObject> detections;  ///< in frame order
  std::set<int> frames;                ///< frames that have a message
  DetectionBagStats stats;
};

/// One DetectedObject as an EvalObject of frame `frame_name`: box, label (labelOf() of
/// `labels`: lower-cased then mapped), score, motion, position and velocity of the message
/// frame (has_state = true), track_id = id, longitudinal distance = x of the position (z = 0) in the velodyne
/// frame, given `velo_from_world`.
EvalObject toEvalObject(const DetectedObject& object, const std::string& frame_name,
                        const Eigen::Isometry3d& velo_from_world, const std::string& label);

/// Reads the DetectedObjectArray messages on config.topic of the bag at `bag_path` and matches
/// them to the frames of `drive` by header stamp (time_s of the objects: the frame's time). `progress`
/// (optional) is called with (messages read, messages on the topic).
/// @throws std::runtime_error naming the bag when it cannot be opened, has no message on the
/// topic (listing the topics it has) or the topic carries another type.
DetectionBagResult readDetectionBag(const std::string& bag_path, const KittiDrive& drive,
                                    const DetectionBagConfig& config, const KittiGroundTruthConfig& labels,
                                    const std::function<void(std::size_t, std::size_t)>& progress = {});

}  // namespace grid_vision_fusion
