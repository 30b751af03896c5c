// rostest: kitti_replay.launch on a short synthetic drive. Collects the objects of the whole
// chain and checks their motion labels against the drive's ground truth (tracklets + OXTS):
// at least 80 % of the matched objects right, moving actors dynamic, parked ones static; and
// that the chain keeps the objects' ids across the replay (tracking, issue 12).
#include <gtest/gtest.h>

#include <algorithm>

#include <diagnostic_msgs/DiagnosticArray.h>
#include <ros/ros.h>
#include <rosgraph_msgs/Clock.h>

#include <map>
#include <mutex>
#include <set>
#include <string>

#include "grid_vision_fusion/DetectedObjectArray.h"
#include "grid_vision_fusion/evaluation/evaluation.h"
#include "grid_vision_fusion/evaluation/kitti_ground_truth.h"
#include "grid_vision_fusion/offline/detection_bag.h"
#include "wait_for.h"

namespace grid_vision_fusion
{
namespace
{
using test::waitFor;

TEST(KittiReplay, MotionLabelsMatchTheGroundTruth)
{
  ros::NodeHandle nh;
  ros::NodeHandle pnh("~");
  std::string drive_dir;
  ASSERT_TRUE(pnh.getParam("drive", drive_dir));
  int frames = 0;
  ASSERT_TRUE(pnh.getParam("frames", frames));
  const KittiDrive drive = KittiDrive::read(drive_dir, "", true);
  ASSERT_EQ(drive.frameCount(), frames);

  std::mutex mutex;
  std::vector<DetectedObjectArray::ConstPtr> received;
  ros::Subscriber sub = nh.subscribe<DetectedObjectArray>("/objects", 100,
                                                          [&](const DetectedObjectArray::ConstPtr& m)
                                                          {
                                                            std::lock_guard<std::mutex> lock(mutex);
                                                            received.push_back(m);
                                                          });
  // The four nodelets' flow on /diagnostics (doc/reliability.md): the latest status of each.
  std::map<std::string, diagnostic_msgs::DiagnosticStatus> diagnostics;
  ros::Subscriber sub_diagnostics =
      nh.subscribe<diagnostic_msgs::DiagnosticArray>("/diagnostics", 100,
                                                     [&](const diagnostic_msgs::DiagnosticArray::ConstPtr& m)
                                                     {
                                                       std::lock_guard<std::mutex> lock(mutex);
                                                       for (const auto& status : m->status)
                                                       {
                                                         diagnostics[status.name] = status;
                                                       }
                                                     });
  // The bag is played with a start delay; wait for its end (the last frame's objects or a
  // pause of 8 s once objects came).
  const ros::Time last_stamp(drive.stamps.back().sec, drive.stamps.back().nsec);
  ros::WallTime last_arrival = ros::WallTime::now();
  std::size_t count = 0;
  ASSERT_TRUE(waitFor(
      [&]
      {
        std::lock_guard<std::mutex> lock(mutex);
        if (received.size() != count)
        {
          count = received.size();
          last_arrival = ros::WallTime::now();
        }
        const bool at_end = !received.empty() && received.back()->header.stamp >= last_stamp;
        return at_end || (count > 0 && (ros::WallTime::now() - last_arrival).toSec() > 8.0);
      },
      90.0))
      << "no objects from the chain";
  ASSERT_GE(received.size(), static_cast<std::size_t>(frames) / 2) << "the chain lost most frames";
  {
    std::lock_guard<std::mutex> lock(mutex);
    for (const char* nodelet : {"dynamic_grid", "yolo_detector", "grid_projection", "fusion"})
    {
      const auto status =
          std::find_if(diagnostics.begin(), diagnostics.end(),
                       [&](const auto& s) { return s.first.find(nodelet) != std::string::npos; });
      ASSERT_NE(status, diagnostics.end()) << "no status of " << nodelet << " on /diagnostics";
      std::map<std::string, std::string> values;
      for (const auto& kv : status->second.values)
      {
        values[kv.key] = kv.value;
      }
      for (const char* key : {"output rate [Hz]", "latency from the sensor stamp, median [s]", "outputs"})
      {
        EXPECT_EQ(values.count(key), 1U) << nodelet << " lacks " << key;
      }
      EXPECT_GT(std::stoul(values["outputs"]), 0UL) << nodelet;
      EXPECT_GE(std::stod(values["latency from the sensor stamp, median [s]"]), 0.0) << nodelet;
    }
  }

  // The objects as evaluation detections, frame by frame.
  const KittiGroundTruthConfig labels;
  const std::vector<GroundTruthObject> truth = trackletGroundTruth(drive, labels);
  const std::vector<double> times = drive.frameTimes();
  // Frame 0's scan and image precede the drive's first OXTS record (the scenario's oxts_delay,
  // as on KITTI raw drives): kitti_to_bag gives them a pose, and the first image's objects come.
  EXPECT_TRUE(std::any_of(received.begin(), received.end(),
                          [&](const DetectedObjectArray::ConstPtr& m) {
                            return nearestFrame(times, m->header.stamp.toSec(), 0.05) == 0 &&
                                   !m->objects.empty();
                          }))
      << "no objects for the first image";
  std::vector<EvalObject> detections;
  for (const auto& msg : received)
  {
    EXPECT_EQ(msg->header.frame_id, "odom") << "the grid's fixed frame: kitti_to_bag's odometry (REP 105)";
    const int frame = nearestFrame(times, msg->header.stamp.toSec(), 0.05);
    ASSERT_GE(frame, 0) << "objects stamped " << msg->header.stamp << " match no image";
    const Eigen::Isometry3d velo_from_odom =
        drive.worldFromVelo(frame).inverse() * drive.worldFromOdom(frame);
    for (const DetectedObject& o : msg->objects)
    {
      detections.push_back(toEvalObject(o, kittiFrameName(frame), velo_from_odom, labels.labelOf(o.label)));
    }
  }
  EvaluationConfig config;
  config.max_longitudinal_m = 40.0;
  const EvaluationResult result = evaluate(evalObjects(truth), detections, config);
  const auto& c = result.motion_confusion;
  const auto kS = static_cast<std::size_t>(Motion::kStatic);
  const auto kD = static_cast<std::size_t>(Motion::kDynamic);
  std::size_t matched = 0;
  for (const auto& row : c)
  {
    for (std::size_t n : row)
    {
      matched += n;
    }
  }
  const std::size_t right = c[kS][kS] + c[kD][kD];
  ::testing::Test::RecordProperty("matched", static_cast<int>(matched));
  ::testing::Test::RecordProperty("right", static_cast<int>(right));
  ASSERT_GE(matched, 40U) << "too few objects matched the ground truth";
  EXPECT_GE(static_cast<double>(right), 0.8 * static_cast<double>(matched))
      << "static->static " << c[kS][kS] << ", static->dynamic " << c[kS][kD] << ", dynamic->dynamic "
      << c[kD][kD] << ", dynamic->static " << c[kD][kS];
  // Both kinds are mostly right on their own.
  EXPECT_GE(c[kS][kS], 4 * c[kS][kD]) << "parked objects called dynamic";
  EXPECT_GE(c[kD][kD], c[kD][kS]) << "moving objects called static";

  // Ids: every actor keeps its id over the replay (at most one switch per 100 matches; the
  // per-frame indices of the paper's output switch on most frames with several objects).
  TrackingEvaluationConfig tracking;
  tracking.max_longitudinal_m = config.max_longitudinal_m;
  const TrackingMetrics t = evaluateTracking(evalObjects(truth), detections, tracking);
  ::testing::Test::RecordProperty("id_switches", static_cast<int>(t.id_switches));
  ASSERT_GE(t.matches, 40U);
  EXPECT_LE(t.id_switches_per_100, 1.0) << t.id_switches << " id switches in " << t.matches << " matches";
  EXPECT_GE(t.idf1, 0.9) << "IDTP " << t.idtp << ", IDFP " << t.idfp << ", IDFN " << t.idfn;
  std::set<std::uint32_t> ids;
  for (const auto& msg : received)
  {
    for (const DetectedObject& o : msg->objects)
    {
      ids.insert(o.id);
    }
  }
  EXPECT_GE(ids.size(), 4U) << "track ids, not indices in the array";
  EXPECT_EQ(ids.count(0U), 0U) << "track ids start at 1";
}

}  // namespace
}  // namespace grid_vision_fusion

int main(int argc, char** argv)
{
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_kitti_replay");
  ros::NodeHandle nh;
  return RUN_ALL_TESTS();
}
