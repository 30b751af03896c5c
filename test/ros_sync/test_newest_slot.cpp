// NewestSlot: a stage slower than its input works on the newest one and drops the older ones
// instead of queueing them; StampCadence: how far apart a stream's stamps come.
#include <gtest/gtest.h>
#include <ros/callback_queue.h>

#include <optional>
#include <vector>

#include "grid_vision_fusion/ros_sync/newest_slot.h"
#include "grid_vision_fusion/ros_sync/stamp_cadence.h"

namespace grid_vision_fusion
{
namespace
{
struct Call
{
  int newest;
  std::optional<int> replaced;
};

TEST(NewestSlot, TheWorkTakesTheNewestInputAndHearsOfTheOnesDropped)
{
  ros::CallbackQueue queue;  // not spun: the work is "busy" until callAvailable()
  std::vector<Call> calls;
  NewestSlot<int> slot(
      [&](const int& newest, const std::optional<int>& replaced) {
        calls.push_back({newest, replaced});
      });
  EXPECT_FALSE(slot.offer(1, queue, 7));
  EXPECT_TRUE(slot.offer(2, queue, 7));  // 1 had not been taken: dropped
  EXPECT_TRUE(slot.offer(3, queue, 7));
  queue.callAvailable();
  ASSERT_EQ(calls.size(), 1U);  // one work call, not three: nothing queued behind it
  EXPECT_EQ(calls[0].newest, 3);
  ASSERT_TRUE(calls[0].replaced.has_value());
  EXPECT_EQ(*calls[0].replaced, 2);  // the newest of the dropped ones

  EXPECT_FALSE(slot.offer(4, queue, 7));  // the slot was empty: scheduled again
  queue.callAvailable();
  ASSERT_EQ(calls.size(), 2U);
  EXPECT_EQ(calls[1].newest, 4);
  EXPECT_FALSE(calls[1].replaced.has_value());
  queue.callAvailable();
  EXPECT_EQ(calls.size(), 2U);  // an empty slot does no work
}

TEST(NewestSlot, InputsThatComeDuringTheWorkWaitInTheSlotForACallbackOfTheirOwn)
{
  ros::CallbackQueue queue;
  std::vector<int> taken;
  NewestSlot<int>* self = nullptr;
  NewestSlot<int> slot(
      [&](const int& newest, const std::optional<int>& /*replaced*/)
      {
        taken.push_back(newest);
        if (newest == 1)
        {
          // Three inputs while the first is worked on: the last one is taken next.
          self->offer(2, queue, 7);
          self->offer(3, queue, 7);
          self->offer(4, queue, 7);
        }
      });
  self = &slot;
  slot.offer(1, queue, 7);
  EXPECT_EQ(queue.callOne(), ros::CallbackQueue::Called);
  EXPECT_EQ(taken, (std::vector<int>{1}));
  // The next input is worked on in a callback posted anew, behind what the queue holds: a
  // thread of the nodelet manager is not kept for as long as the inputs come.
  EXPECT_FALSE(queue.isEmpty());
  EXPECT_EQ(queue.callOne(), ros::CallbackQueue::Called);
  EXPECT_EQ(taken, (std::vector<int>{1, 4}));
  EXPECT_EQ(queue.callOne(), ros::CallbackQueue::Empty);
}

TEST(NewestSlot, AfterEndNothingIsWorkedOn)
{
  ros::CallbackQueue queue;
  int calls = 0;
  NewestSlot<int> slot([&](const int&, const std::optional<int>&) { ++calls; });
  slot.offer(1, queue, 7);
  slot.end();
  queue.callAvailable();
  EXPECT_EQ(calls, 0);
}

TEST(StampCadence, SecondLongestOfTheLastIntervals)
{
  StampCadence cadence;
  EXPECT_EQ(cadence.interval(), 0.0);
  const ros::Time t0(1000, 0);
  cadence.add(t0);
  EXPECT_EQ(cadence.interval(), 0.0);  // one stamp: no interval yet
  cadence.add(t0 + ros::Duration(0.1));
  EXPECT_NEAR(cadence.interval(), 0.1, 1e-9);  // the only interval
  for (int i = 2; i <= 6; ++i)
  {
    cadence.add(t0 + ros::Duration(0.1 * i));
  }
  EXPECT_NEAR(cadence.interval(), 0.1, 1e-9);
  // One long gap (an outage) does not set it.
  cadence.add(t0 + ros::Duration(30.6));
  EXPECT_NEAR(cadence.interval(), 0.1, 1e-9);
  // A stage slower than its input delivers in bursts and pauses: 0.2-0.9 s apart.
  double t = 30.6;
  for (const double interval : {0.2, 0.9, 0.2, 0.6})
  {
    t += interval;
    cadence.add(t0 + ros::Duration(t));
  }
  EXPECT_NEAR(cadence.interval(), 0.9, 1e-9);  // of 30.0, 0.2, 0.9, 0.2, 0.6
  t += 0.3;
  cadence.add(t0 + ros::Duration(t));
  EXPECT_NEAR(cadence.interval(), 0.6, 1e-9);  // of 0.2, 0.9, 0.2, 0.6, 0.3
  // Time going backwards (a bag loop) starts over.
  cadence.add(t0);
  EXPECT_EQ(cadence.interval(), 0.0);
  cadence.add(t0 + ros::Duration(0.2));
  EXPECT_NEAR(cadence.interval(), 0.2, 1e-9);
  cadence.clear();
  EXPECT_EQ(cadence.interval(), 0.0);
}

}  // namespace
}  // namespace grid_vision_fusion
