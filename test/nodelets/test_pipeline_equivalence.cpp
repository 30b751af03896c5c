// rostest: the offline Pipeline (run_pipeline) and the nodelet chain give the same objects on
// the same short synthetic drive: same object arrays for the frames both produced, same track
// ids and motion labels, positions within 0.1 m; two Pipeline runs give identical bytes.
#include <gtest/gtest.h>

#include <nodelet/loader.h>
#include <ros/ros.h>
#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <rosgraph_msgs/Clock.h>
#include <topic_tools/shape_shifter.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <mutex>
#include <set>

#include "grid_vision_fusion/offline/kitti_bag_writer.h"
#include "grid_vision_fusion/offline/pipeline.h"
#include "grid_vision_fusion/simulation/synthetic_drive.h"
#include "wait_for.h"

namespace grid_vision_fusion
{
namespace
{
namespace fs = std::filesystem;
const std::string kSource = GVF_SOURCE_DIR;

/// A 2.5 s drive (25 frames): the ego at 10 m/s, a car ahead at 12 m/s in the ego lane, an
/// oncoming car, a crossing car, parked cars on both sides; a reduced lidar (768 columns). As on
/// KITTI raw drives, each frame's OXTS record comes 13 ms after its scan and image (the first
/// frame has no earlier pose: kitti_to_bag gives it one).
const char* const kScenario = R"(
seed: 7
duration: 2.5
frame_rate: 10.0
oxts_delay: 0.013
road: {center_y: 0.0, half_width: 7.0, lane_width: 3.5}
lidar: {azimuth_steps: 768, range_noise_std: 0.02, dropout: 0.02}
ego:
  waypoints: [[0.0, 0.0, -1.75], [2.5, 25.0, -1.75]]
actors:
  - {type: Car, size: [4.3, 1.8, 1.5], color: "#B03A2E", parked: {x: 22.0, y: -5.2, yaw: 0.0}}
  - {type: Van, size: [5.0, 2.0, 2.2], color: "#F4F6F7", parked: {x: 35.0, y: 5.2, yaw: 3.1416}}
  - {type: Car, size: [4.5, 1.8, 1.5], color: "#884EA0", waypoints: [[0.0, 15.0, -1.75], [2.5, 45.0, -1.75]]}
  - {type: Car, size: [4.3, 1.8, 1.45], color: "#CA6F1E", waypoints: [[0.0, 60.0, 1.75], [2.5, 35.0, 1.75]]}
  - {type: Car, size: [4.3, 1.8, 1.5], color: "#C0392B", waypoints: [[0.0, 40.0, -15.0], [2.5, 40.0, 10.0]]}
scenery:
  - {x: 20.0, y: -14.0, yaw: 0.0, size: [60.0, 8.0, 12.0], color: "#A89F91"}
  - {x: 20.0, y: 14.0, yaw: 0.0, size: [60.0, 8.0, 10.0], color: "#B7A99A"}
)";

struct Drive
{
  std::string dir;
  std::string bag;
  std::size_t frames = 0;
};

/// The drive and its bag, made once for all tests of this process.
const Drive& drive()
{
  static Drive d;
  if (d.bag.empty())
  {
    char pattern[] = "/tmp/gvf_pipeline_eq_XXXXXX";
    const char* root = mkdtemp(pattern);
    if (!root)
    {
      throw std::runtime_error("mkdtemp failed");
    }
    const std::string scenario_path = std::string(root) + "/scenario.yaml";
    std::ofstream(scenario_path) << kScenario;
    SyntheticDriveOptions options;
    options.output_root = std::string(root) + "/kitti";
    options.calibration_dir = kSource + "/data/calibration/2011_09_26";
    const SyntheticDriveSummary summary = writeSyntheticDrive(loadScenario(scenario_path), options);
    KittiBagOptions bag;
    bag.drive_dir = summary.drive_dir;
    bag.output_bag = std::string(root) + "/drive.bag";
    convertKittiDrive(bag);
    d.dir = summary.drive_dir;
    d.frames = static_cast<std::size_t>(summary.frames);
    d.bag = bag.output_bag;
  }
  return d;
}

/// The pipeline configuration run_pipeline builds from the package's YAML files for the replay
/// backend on a kitti_to_bag drive (as kitti_replay.launch).
PipelineConfig replayConfig(const std::string& label_dir)
{
  const std::string dir = kSource + "/config";
  YamlParamSource detector = YamlParamSource::fromFile(dir + "/yolo_detector.yaml");
  detector.set("backend", std::string("replay"));
  detector.set("replay/directory", label_dir);
  detector.set("replay/file_pattern", std::string("%010d.txt"));
  detector.set("replay/frame_index", std::string("seq"));
  return pipelineConfigFromParams(YamlParamSource::fromFile(dir + "/dynamic_grid.yaml"), detector,
                                  YamlParamSource::fromFile(dir + "/grid_projection.yaml"),
                                  YamlParamSource::fromFile(dir + "/fusion.yaml"));
}

using ObjectsByStamp = std::map<ros::Time, DetectedObjectArray::ConstPtr>;

/// The objects of a run by stamp; `order` (when given) receives the stamps in output order.
ObjectsByStamp runPipeline(bool overlap_detector = true, std::vector<ros::Time>* order = nullptr)
{
  ObjectsByStamp out;
  PipelineOutputs outputs;
  outputs.objects = [&](const DetectedObjectArray::ConstPtr& m)
  {
    out[m->header.stamp] = m;
    if (order)
    {
      order->push_back(m->header.stamp);
    }
  };
  PipelineConfig config = replayConfig(drive().dir + "/label_2");
  config.overlap_detector = overlap_detector;
  Pipeline pipeline(config, outputs);
  runPipelineOnBag(pipeline, drive().bag, PipelineTopics());
  return out;
}

std::vector<std::uint8_t> bytesOf(const DetectedObjectArray& msg)
{
  std::vector<std::uint8_t> bytes(ros::serialization::serializationLength(msg));
  ros::serialization::OStream stream(bytes.data(), static_cast<std::uint32_t>(bytes.size()));
  ros::serialization::serialize(stream, msg);
  return bytes;
}

TEST(PipelineEquivalence, TwoRunsGiveIdenticalOutput)
{
  const ObjectsByStamp a = runPipeline();
  const ObjectsByStamp b = runPipeline();
  ASSERT_EQ(a.size(), b.size());
  ASSERT_EQ(a.size(), drive().frames);
  std::size_t objects = 0;
  for (const auto& [stamp, msg] : a)
  {
    ASSERT_EQ(b.count(stamp), 1U);
    EXPECT_EQ(bytesOf(*msg), bytesOf(*b.at(stamp))) << "objects at t=" << stamp;
    objects += msg->objects.size();
  }
  EXPECT_GT(objects, 0U);
}

TEST(PipelineEquivalence, TheOverlappedDetectorChangesNothing)
{
  std::vector<ros::Time> order_overlapped;
  std::vector<ros::Time> order_sequential;
  const ObjectsByStamp overlapped = runPipeline(true, &order_overlapped);
  const ObjectsByStamp sequential = runPipeline(false, &order_sequential);
  EXPECT_EQ(order_overlapped, order_sequential);
  ASSERT_EQ(overlapped.size(), sequential.size());
  ASSERT_EQ(overlapped.size(), drive().frames);
  for (const auto& [stamp, msg] : overlapped)
  {
    ASSERT_EQ(sequential.count(stamp), 1U);
    EXPECT_EQ(bytesOf(*msg), bytesOf(*sequential.at(stamp))) << "objects at t=" << stamp;
  }
}

/// The outputs of the chain, by stamp.
struct ChainOutputs
{
  std::mutex mutex;
  std::set<ros::Time> grids, detections, projections;
  ObjectsByStamp objects;
  bool has(const std::set<ros::Time>& set, const ros::Time& t)
  {
    std::lock_guard<std::mutex> lock(mutex);
    return set.count(t) > 0;
  }
};

TEST(PipelineEquivalence, SameObjectsAsTheNodeletChain)
{
  const Drive& d = drive();
  const ObjectsByStamp offline = runPipeline();

  ros::NodeHandle nh;
  ros::param::set("/yolo_detector/backend", std::string("replay"));
  ros::param::set("/yolo_detector/replay/directory", d.dir + "/label_2");
  ros::param::set("/yolo_detector/replay/file_pattern", std::string("%010d.txt"));
  ros::param::set("/yolo_detector/replay/frame_index", std::string("seq"));

  // The chain: the four nodelets in this process, topics as perception.launch names them.
  nodelet::Loader loader(false);
  const nodelet::M_string remap;
  const nodelet::V_string args;
  for (const std::string name : {"dynamic_grid", "yolo_detector", "grid_projection", "fusion"})
  {
    ASSERT_TRUE(loader.load("/" + name, "grid_vision_fusion/" + name, remap, args)) << name;
  }

  ChainOutputs out;
  auto sub_grid = nh.subscribe<DynamicGrid>("grid", 100,
                                            [&](const DynamicGrid::ConstPtr& m)
                                            {
                                              std::lock_guard<std::mutex> lock(out.mutex);
                                              out.grids.insert(m->header.stamp);
                                            });
  auto sub_det = nh.subscribe<Detection2DArray>("detections", 100,
                                                [&](const Detection2DArray::ConstPtr& m)
                                                {
                                                  std::lock_guard<std::mutex> lock(out.mutex);
                                                  out.detections.insert(m->header.stamp);
                                                });
  auto sub_proj = nh.subscribe<ProjectedGrid>("projected_grid", 100,
                                              [&](const ProjectedGrid::ConstPtr& m)
                                              {
                                                std::lock_guard<std::mutex> lock(out.mutex);
                                                out.projections.insert(m->header.stamp);
                                              });
  auto sub_obj = nh.subscribe<DetectedObjectArray>("objects", 100,
                                                   [&](const DetectedObjectArray::ConstPtr& m)
                                                   {
                                                     std::lock_guard<std::mutex> lock(out.mutex);
                                                     out.objects[m->header.stamp] = m;
                                                   });

  // The bag's messages, published as rosbag play does (ShapeShifter: the bytes as recorded,
  // header.seq included) on the chain's input topics.
  const PipelineTopics topics;
  const std::map<std::string, std::string> input_topic{{topics.points, "points"},
                                                       {topics.image, "image"},
                                                       {topics.camera_info, "camera_info"},
                                                       {topics.tf, "/tf"},
                                                       {topics.tf_static, "/tf_static"}};
  rosbag::Bag bag(d.bag, rosbag::bagmode::Read);
  std::vector<std::string> wanted;
  for (const auto& [from, to] : input_topic)
  {
    wanted.push_back(from);
  }
  rosbag::View view(bag, rosbag::TopicQuery(wanted));
  std::map<std::string, ros::Publisher> publishers;
  for (const rosbag::MessageInstance& m : view)
  {
    if (!publishers.count(m.getTopic()))
    {
      auto msg = m.instantiate<topic_tools::ShapeShifter>();
      publishers[m.getTopic()] =
          msg->advertise(nh, input_topic.at(m.getTopic()), 100, m.getTopic() == topics.tf_static);
    }
  }
  ros::Publisher clock = nh.advertise<rosgraph_msgs::Clock>("/clock", 10);
  ASSERT_TRUE(test::waitFor(
      [&]
      {
        for (const auto& [topic, pub] : publishers)
        {
          if (pub.getNumSubscribers() == 0)
          {
            return false;
          }
        }
        return true;
      },
      20.0))
      << "the lazy chain did not subscribe to its inputs";

  // In the pipeline's order: per stamp tf, cloud, image, camera_info; each waits for its output.
  // A frame's pose comes 13 ms after its scan (oxts_delay), and the scan's grid needs it: tf is
  // sent up to kTfLead ahead of its stamp, as the queue a player fills would hold it by then.
  struct Item
  {
    ros::Time stamp;
    int rank;
    std::size_t order;
    std::shared_ptr<const rosbag::MessageInstance> message;
  };
  std::vector<Item> items;
  for (const rosbag::MessageInstance& m : view)
  {
    const std::string& t = m.getTopic();
    const int rank = t == topics.tf_static ? 0
                     : t == topics.tf      ? 1
                     : t == topics.points  ? 2
                     : t == topics.image   ? 3
                                           : 4;
    items.push_back({m.getTime(), rank, items.size(), std::make_shared<const rosbag::MessageInstance>(m)});
  }
  const ros::Duration kTfLead(0.05);
  const auto sent_at = [&](const Item& item) { return item.rank <= 1 ? item.stamp - kTfLead : item.stamp; };
  std::stable_sort(items.begin(), items.end(),
                   [&](const Item& a, const Item& b)
                   { return sent_at(a) != sent_at(b) ? sent_at(a) < sent_at(b) : a.rank < b.rank; });
  std::set<ros::Time> image_stamps;
  rosgraph_msgs::Clock now;  // never back: a tf sent ahead moves it on
  for (const Item& item : items)
  {
    now.clock = std::max(now.clock, item.stamp);
    clock.publish(now);
    const std::string& topic = item.message->getTopic();
    publishers.at(topic).publish(item.message->instantiate<topic_tools::ShapeShifter>());
    if (topic == topics.points)
    {
      ros::Time stamp = item.message->instantiate<sensor_msgs::PointCloud2>()->header.stamp;
      EXPECT_TRUE(test::waitFor([&] { return out.has(out.grids, stamp); }, 10.0)) << "no grid at t=" << stamp;
    }
    else if (topic == topics.image)
    {
      ros::Time stamp = item.message->instantiate<sensor_msgs::Image>()->header.stamp;
      image_stamps.insert(stamp);
      EXPECT_TRUE(test::waitFor([&] { return out.has(out.detections, stamp); }, 10.0))
          << "no detections at t=" << stamp;
    }
    else if (topic == topics.camera_info)
    {
      ros::Time stamp = item.message->instantiate<sensor_msgs::CameraInfo>()->header.stamp;
      if (test::waitFor([&] { return out.has(out.projections, stamp); }, 3.0) &&
          out.has(out.detections, stamp))
      {
        EXPECT_TRUE(test::waitFor(
            [&]
            {
              std::lock_guard<std::mutex> lock(out.mutex);
              return out.objects.count(stamp) > 0;
            },
            10.0))
            << "no objects at t=" << stamp;
      }
    }
  }
  test::waitFor([] { return false; }, 0.3);  // late messages
  loader.clear();

  std::lock_guard<std::mutex> lock(out.mutex);
  const ObjectsByStamp& chain = out.objects;
  // Both produce objects for every image, the first one included.
  EXPECT_EQ(chain.size(), image_stamps.size());
  EXPECT_EQ(offline.size(), image_stamps.size());
  ASSERT_FALSE(image_stamps.empty());
  const ros::Time first_image = *image_stamps.begin();
  EXPECT_TRUE(chain.count(first_image) && !chain.at(first_image)->objects.empty())
      << "the chain has no objects for the first image";
  EXPECT_TRUE(offline.count(first_image) && !offline.at(first_image)->objects.empty())
      << "the pipeline has no objects for the first image";
  std::size_t compared_frames = 0, compared_objects = 0, dynamic = 0;
  for (const auto& [stamp, online_msg] : chain)
  {
    const auto it = offline.find(stamp);
    if (it == offline.end())
    {
      ADD_FAILURE() << "the chain has objects at t=" << stamp << ", the pipeline has none";
      continue;
    }
    const DetectedObjectArray& a = *it->second;
    const DetectedObjectArray& b = *online_msg;
    ++compared_frames;
    EXPECT_EQ(a.header.frame_id, b.header.frame_id);
    ASSERT_EQ(a.objects.size(), b.objects.size()) << "t=" << stamp;
    for (std::size_t i = 0; i < a.objects.size(); ++i)
    {
      const DetectedObject& p = a.objects[i];
      const DetectedObject& q = b.objects[i];
      EXPECT_EQ(p.label, q.label) << "t=" << stamp << " object " << i;
      EXPECT_EQ(p.id, q.id) << "t=" << stamp << " object " << i << " (" << p.label << ")";
      EXPECT_EQ(p.motion, q.motion) << "t=" << stamp << " object " << i << " (" << p.label << ")";
      EXPECT_NEAR(p.p_dynamic, q.p_dynamic, 1e-3) << "t=" << stamp << " object " << i;
      EXPECT_EQ(p.track_state, q.track_state) << "t=" << stamp << " object " << i;
      EXPECT_NEAR(p.position.x, q.position.x, 0.1) << "t=" << stamp << " object " << i;
      EXPECT_NEAR(p.position.y, q.position.y, 0.1) << "t=" << stamp << " object " << i;
      ++compared_objects;
      dynamic += p.motion == DetectedObject::MOTION_DYNAMIC ? 1 : 0;
    }
  }
  for (const auto& [stamp, msg] : offline)
  {
    EXPECT_TRUE(chain.count(stamp)) << "the pipeline has objects at t=" << stamp << ", the chain has none";
  }
  EXPECT_EQ(compared_frames, image_stamps.size());
  EXPECT_GT(compared_objects, 2 * compared_frames / 2);  // objects were really compared
  std::cout << "compared " << compared_objects << " objects (" << dynamic << " dynamic) in "
            << compared_frames << " frames\n";
}

}  // namespace
}  // namespace grid_vision_fusion

int main(int argc, char** argv)
{
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_pipeline_equivalence");
  ros::NodeHandle nh;
  const int result = RUN_ALL_TESTS();
  const std::string& bag = grid_vision_fusion::drive().bag;  // the drive's temporary folder
  std::filesystem::remove_all(std::filesystem::path(bag).parent_path());
  return result;
}
