// rostest: two nodelets loaded into one nodelet manager (a nodelet::Loader, exactly what the
// `nodelet manager` process runs) exchange this package's messages; the receiver must see the
// very object the sender published (pointer identity), i.e. no serialisation and no copy.
#include <gtest/gtest.h>

#include <nodelet/loader.h>
#include <nodelet/nodelet.h>
#include <ros/ros.h>
#include <boost/make_shared.hpp>

#include <atomic>
#include <mutex>

#include "grid_vision_fusion/DetectedObjectArray.h"
#include "grid_vision_fusion/ProjectedGrid.h"

namespace grid_vision_fusion
{
namespace
{
/// Publishes freshly allocated messages and remembers their addresses.
class SenderNodelet : public nodelet::Nodelet
{
public:
  void onInit() override
  {
    pub_objects_ = getNodeHandle().advertise<DetectedObjectArray>("zero_copy/objects", 1);
    pub_grid_ = getNodeHandle().advertise<ProjectedGrid>("zero_copy/projected_grid", 1);
  }
  bool connected() const { return pub_objects_.getNumSubscribers() > 0 && pub_grid_.getNumSubscribers() > 0; }
  void send()
  {
    auto objects = boost::make_shared<DetectedObjectArray>();
    objects->objects.resize(3);
    auto grid = boost::make_shared<ProjectedGrid>();
    grid->u.assign(100000, 1.F);
    sent_objects = objects.get();
    sent_grid = grid.get();
    pub_objects_.publish(objects);
    pub_grid_.publish(grid);
  }
  std::atomic<const void*> sent_objects{nullptr};
  std::atomic<const void*> sent_grid{nullptr};

private:
  ros::Publisher pub_objects_, pub_grid_;
};

/// Records the addresses of what it receives.
class ReceiverNodelet : public nodelet::Nodelet
{
public:
  void onInit() override
  {
    sub_objects_ = getNodeHandle().subscribe("zero_copy/objects", 1, &ReceiverNodelet::objectsCb, this);
    sub_grid_ = getNodeHandle().subscribe("zero_copy/projected_grid", 1, &ReceiverNodelet::gridCb, this);
  }
  void objectsCb(const DetectedObjectArray::ConstPtr& msg)
  {
    std::lock_guard<std::mutex> lock(mutex_);
    objects_ = msg;
  }
  void gridCb(const ProjectedGrid::ConstPtr& msg)
  {
    std::lock_guard<std::mutex> lock(mutex_);
    grid_ = msg;
  }
  std::pair<const void*, const void*> received()
  {
    std::lock_guard<std::mutex> lock(mutex_);
    return {objects_.get(), grid_.get()};
  }

private:
  ros::Subscriber sub_objects_, sub_grid_;
  std::mutex mutex_;
  DetectedObjectArray::ConstPtr objects_;
  ProjectedGrid::ConstPtr grid_;
};

TEST(ZeroCopy, ReceiverSeesTheSenderObject)
{
  // The manager owns the nodelets; the test only observes them.
  SenderNodelet* sender = nullptr;
  ReceiverNodelet* receiver = nullptr;
  nodelet::Loader manager(
      [&](const std::string& type) -> boost::shared_ptr<nodelet::Nodelet>
      {
        if (type == "test/sender")
        {
          auto nodelet = boost::make_shared<SenderNodelet>();
          sender = nodelet.get();
          return nodelet;
        }
        if (type == "test/receiver")
        {
          auto nodelet = boost::make_shared<ReceiverNodelet>();
          receiver = nodelet.get();
          return nodelet;
        }
        return nullptr;
      });
  const nodelet::M_string remappings;
  const nodelet::V_string args;
  ASSERT_TRUE(manager.load("/sender", "test/sender", remappings, args));
  ASSERT_TRUE(manager.load("/receiver", "test/receiver", remappings, args));
  ASSERT_TRUE(sender && receiver);

  const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(10.0);
  while (!sender->connected() && ros::WallTime::now() < deadline)
  {
    ros::WallDuration(0.01).sleep();
  }
  ASSERT_TRUE(sender->connected());
  sender->send();
  std::pair<const void*, const void*> got{nullptr, nullptr};
  while ((got.first == nullptr || got.second == nullptr) && ros::WallTime::now() < deadline)
  {
    ros::WallDuration(0.01).sleep();
    got = receiver->received();
  }
  ASSERT_NE(got.first, nullptr) << "DetectedObjectArray never arrived";
  ASSERT_NE(got.second, nullptr) << "ProjectedGrid never arrived";
  EXPECT_EQ(got.first, sender->sent_objects.load()) << "DetectedObjectArray was copied";
  EXPECT_EQ(got.second, sender->sent_grid.load()) << "ProjectedGrid was copied";
}

}  // namespace
}  // namespace grid_vision_fusion

int main(int argc, char** argv)
{
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_zero_copy");
  ros::NodeHandle nh;
  return RUN_ALL_TESTS();
}
