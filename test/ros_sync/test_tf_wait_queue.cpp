// TfWaitQueue without a master: a hand-fed tf2::BufferCore, camera_infos as the messages.
#include <gtest/gtest.h>

#include <geometry_msgs/TransformStamped.h>
#include <ros/callback_queue.h>
#include <sensor_msgs/CameraInfo.h>
#include <boost/make_shared.hpp>

#include <atomic>
#include <memory>
#include <thread>

#include "grid_vision_fusion/ros_sync/tf_wait_queue.h"

namespace grid_vision_fusion
{
namespace
{
using Queue = TfWaitQueue<sensor_msgs::CameraInfo>;

sensor_msgs::CameraInfo::ConstPtr info(double stamp_s, const std::string& frame = "camera")
{
  auto msg = boost::make_shared<sensor_msgs::CameraInfo>();
  msg->header.stamp = ros::Time(stamp_s);
  msg->header.frame_id = frame;
  return msg;
}

void setTf(tf2::BufferCore& buffer, const std::string& parent, const std::string& child, double stamp_s)
{
  geometry_msgs::TransformStamped t;
  t.header.frame_id = parent;
  t.header.stamp = ros::Time(stamp_s);
  t.child_frame_id = child;
  t.transform.rotation.w = 1.0;
  buffer.setTransform(t, "test");
}

/// A queue of `capacity` on `buffer` that records the stamps it passes on and drops.
struct Recorder
{
  explicit Recorder(const tf2::BufferCore& buffer, std::size_t capacity = 3)
      : queue(
            buffer, capacity,
            [this](const sensor_msgs::CameraInfo::ConstPtr& m) { ready.push_back(m->header.stamp.toSec()); },
            [this](const sensor_msgs::CameraInfo::ConstPtr& m, TfWaitDrop why)
            { dropped.emplace_back(m->header.stamp.toSec(), why); })
  {
    queue.setTargetFrames({"world"});
  }
  std::vector<double> ready;
  std::vector<std::pair<double, TfWaitDrop>> dropped;
  Queue queue;
};
}  // namespace

TEST(TfWaitQueue, AMessageGoesOnOnceItsTfIsThereInArrivalOrder)
{
  tf2::BufferCore buffer;
  setTf(buffer, "world", "camera", 10.0);
  Recorder r(buffer);
  r.queue.add(info(10.0));  // its tf is there
  EXPECT_EQ(r.ready, (std::vector<double>{10.0}));
  r.queue.add(info(10.1));  // not yet: extrapolation into the future
  r.queue.add(info(10.2));
  r.queue.poll();
  EXPECT_EQ(r.ready.size(), 1U);
  EXPECT_EQ(r.queue.size(), 2U);
  setTf(buffer, "world", "camera", 10.2);
  r.queue.poll();
  EXPECT_EQ(r.ready, (std::vector<double>{10.0, 10.1, 10.2}));
  EXPECT_EQ(r.queue.size(), 0U);
  EXPECT_TRUE(r.dropped.empty());
}

TEST(TfWaitQueue, TheOldestIsDroppedWhenFullAndAnEmptyFrameAtOnce)
{
  tf2::BufferCore buffer;
  Recorder r(buffer, 2);
  r.queue.add(info(1.0));
  r.queue.add(info(2.0));
  r.queue.add(info(3.0));
  ASSERT_EQ(r.dropped.size(), 1U);
  EXPECT_EQ(r.dropped[0], std::make_pair(1.0, TfWaitDrop::kQueueFull));
  r.queue.add(info(4.0, ""));
  ASSERT_EQ(r.dropped.size(), 2U);
  EXPECT_EQ(r.dropped[1], std::make_pair(4.0, TfWaitDrop::kEmptyFrameId));
  EXPECT_EQ(r.queue.size(), 2U);
  r.queue.clear();
  EXPECT_EQ(r.queue.size(), 0U);
  EXPECT_TRUE(r.ready.empty());
}

TEST(TfWaitQueue, NewTargetFramesApplyToTheWaitingMessages)
{
  // A camera_info queued while the grid was in a frame without a tf to the camera goes on once
  // the grid's frame is one with a tf (tf2_ros::MessageFilter kept it waiting for the old one).
  tf2::BufferCore buffer;
  setTf(buffer, "world", "camera", 5.0);
  Recorder r(buffer);
  r.queue.setTargetFrames({"elsewhere"});
  r.queue.add(info(5.0));
  r.queue.poll();
  EXPECT_TRUE(r.ready.empty());
  EXPECT_EQ(r.queue.targetFramesString(), "elsewhere");
  r.queue.setTargetFrames({"world", "camera"});
  EXPECT_EQ(r.queue.targetFramesString(), "world camera");
  r.queue.poll();
  EXPECT_EQ(r.ready, (std::vector<double>{5.0}));
  r.queue.setTargetFrames({});
  r.queue.add(info(99.0, "nowhere"));  // no target frame: nothing to wait for
  EXPECT_EQ(r.ready.back(), 99.0);
}

TEST(TfWaitQueue, EachMessageCanWaitForItsOwnFrames)
{
  // The grid projection's requests: each waits for the tf to the frame of its own grid.
  tf2::BufferCore buffer;
  setTf(buffer, "world", "camera", 5.0);
  std::vector<std::string> ready;
  Queue queue(
      buffer, 3, [&](const sensor_msgs::CameraInfo::ConstPtr& m) { ready.push_back(m->distortion_model); },
      [](const sensor_msgs::CameraInfo::ConstPtr&, TfWaitDrop) {},
      [](const sensor_msgs::CameraInfo& m) { return std::vector<std::string>{m.distortion_model}; });
  auto to_elsewhere = boost::make_shared<sensor_msgs::CameraInfo>(*info(5.0));
  to_elsewhere->distortion_model = "elsewhere";  // stands for the message's target frame
  auto to_world = boost::make_shared<sensor_msgs::CameraInfo>(*info(5.0));
  to_world->distortion_model = "world";
  queue.add(to_elsewhere);
  queue.add(to_world);
  EXPECT_EQ(ready, (std::vector<std::string>{"world"}));
  EXPECT_EQ(queue.size(), 1U);
  setTf(buffer, "world", "elsewhere", 5.0);
  queue.poll();
  EXPECT_EQ(ready, (std::vector<std::string>{"world", "elsewhere"}));
}

TEST(TfWaitQueue, NoMessageIsLostToATfArrivingWhileItIsAdded)
{
  // The race that loses tf2_ros::MessageFilter's messages: every tf arrives on another thread
  // while its message is being added. Every message must come through, at the latest at the
  // poll after its tf.
  tf2::BufferCore buffer;
  Recorder r(buffer, 1000);
  constexpr int kMessages = 300;
  std::atomic<int> added{0};
  std::thread tf_thread(
      [&]
      {
        for (int k = 0; k < kMessages; ++k)
        {
          while (added.load() < k)
          {
            std::this_thread::yield();
          }
          setTf(buffer, "world", "camera", 1.0 + 0.01 * k);
        }
      });
  for (int k = 0; k < kMessages; ++k)
  {
    r.queue.add(info(1.0 + 0.01 * k));
    added.store(k + 1);
  }
  tf_thread.join();
  r.queue.poll();
  EXPECT_EQ(r.ready.size(), static_cast<std::size_t>(kMessages));
  EXPECT_EQ(r.queue.size(), 0U);
  EXPECT_TRUE(r.dropped.empty());
}

TEST(TfWaitQueue, TheWakeupPollsOnTheCallbackQueueWhenATransformArrives)
{
  // A message waiting for its tf goes on from the callback queue as soon as the tf arrives,
  // without waiting for a timer; one poll is pending at most however many transforms come.
  tf2::BufferCore buffer;
  Recorder r(buffer);
  ros::CallbackQueue callbacks;
  int polls = 0;
  {
    TfWaitWakeup wakeup(buffer, callbacks,
                        [&]
                        {
                          ++polls;
                          r.queue.poll();
                        });
    r.queue.add(info(7.0));
    EXPECT_TRUE(callbacks.empty());
    setTf(buffer, "world", "camera", 6.9);
    setTf(buffer, "world", "camera", 7.0);
    EXPECT_TRUE(r.ready.empty()) << "the poll runs on the callback queue, not in the tf thread";
    callbacks.callAvailable();
    EXPECT_EQ(r.ready, (std::vector<double>{7.0}));
    EXPECT_TRUE(callbacks.empty());
    setTf(buffer, "world", "camera", 7.1);
    EXPECT_FALSE(callbacks.empty());
  }
  EXPECT_EQ(polls, 1);
  callbacks.callAvailable();
  EXPECT_EQ(polls, 1) << "a poll queued before the wakeup went does nothing";
  setTf(buffer, "world", "camera", 7.2);
  EXPECT_TRUE(callbacks.empty()) << "a gone wakeup no longer listens to tf";
}

TEST(TfWaitQueue, TheWakeupOutlivesItsCallbackQueueAtShutdown)
{
  // The nodelet manager may free a nodelet's callback queues before it deletes the nodelet: the
  // wakeup must not touch its queue when it goes (the sanitizer build tells a read of the freed
  // queue).
  tf2::BufferCore buffer;
  Recorder r(buffer);
  auto callbacks = std::make_unique<ros::CallbackQueue>();
  auto wakeup = std::make_unique<TfWaitWakeup>(buffer, *callbacks, [&] { r.queue.poll(); });
  r.queue.add(info(7.0));
  setTf(buffer, "world", "camera", 7.0);
  EXPECT_FALSE(callbacks->empty());
  callbacks.reset();
  wakeup.reset();
  EXPECT_TRUE(r.ready.empty());
}

}  // namespace grid_vision_fusion
