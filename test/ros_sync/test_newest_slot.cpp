// NewestSlot: a stage slower than its input works on the newest one and drops the older ones
// instead of queueing them; StampCadence: how far apart a stream's stamps come.
#include <gtest/gtest.h>
#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <chrono>
#include <condition_variable>
#include <mutex>
#include <optional>
#include <stdexcept>
#include <thread>
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

/// What the slot's work did, and a gate that holds it busy on its first input until opened.
class Recorder
{
public:
  void work(int newest, const std::optional<int>& replaced)
  {
    std::unique_lock<std::mutex> lock(mutex_);
    calls_.push_back({newest, replaced});
    thread_ = std::this_thread::get_id();
    errno = 0;
    nice_ = getpriority(PRIO_PROCESS, static_cast<id_t>(syscall(SYS_gettid)));
    changed_.notify_all();
    changed_.wait(lock, [this] { return open_; });
  }

  void open()
  {
    std::lock_guard<std::mutex> lock(mutex_);
    open_ = true;
    changed_.notify_all();
  }

  /// The calls once there are `count` of them (fails the test after 5 s).
  std::vector<Call> waitFor(std::size_t count)
  {
    std::unique_lock<std::mutex> lock(mutex_);
    EXPECT_TRUE(changed_.wait_for(lock, std::chrono::seconds(5), [&] { return calls_.size() >= count; }))
        << "the work was called " << calls_.size() << " times, not " << count;
    return calls_;
  }

  std::thread::id thread()
  {
    std::lock_guard<std::mutex> lock(mutex_);
    return thread_;
  }

  /// The nice value of the work's thread.
  int nice()
  {
    std::lock_guard<std::mutex> lock(mutex_);
    return nice_;
  }

private:
  std::mutex mutex_;
  std::condition_variable changed_;
  std::vector<Call> calls_;
  std::thread::id thread_;
  int nice_ = 0;
  bool open_ = false;
};

TEST(NewestSlot, TheWorkTakesTheNewestInputOnANicerThreadOfItsOwnAndHearsOfTheOnesDropped)
{
  Recorder recorder;
  NewestSlot<int> slot("test_slot", [&](const int& newest, const std::optional<int>& replaced)
                       { recorder.work(newest, replaced); });
  EXPECT_FALSE(slot.offer(1));
  recorder.waitFor(1);  // the work is busy on 1, and offer() returned meanwhile
  EXPECT_NE(recorder.thread(), std::this_thread::get_id());
  errno = 0;
  const int own_nice = getpriority(PRIO_PROCESS, static_cast<id_t>(syscall(SYS_gettid)));
  EXPECT_EQ(recorder.nice(), std::min(own_nice + NewestSlot<int>::kNiceIncrement, 19));
  EXPECT_FALSE(slot.offer(2));  // the slot was empty
  EXPECT_TRUE(slot.offer(3));   // 2 had not been taken: dropped
  EXPECT_TRUE(slot.offer(4));
  recorder.open();
  const std::vector<Call> calls = recorder.waitFor(2);
  ASSERT_EQ(calls.size(), 2U);  // two work calls, not four: nothing queued behind the first
  EXPECT_EQ(calls[0].newest, 1);
  EXPECT_FALSE(calls[0].replaced.has_value());
  EXPECT_EQ(calls[1].newest, 4);
  ASSERT_TRUE(calls[1].replaced.has_value());
  EXPECT_EQ(*calls[1].replaced, 3);  // the newest of the dropped ones

  EXPECT_FALSE(slot.offer(5));  // the work is idle: taken at once
  const std::vector<Call> more = recorder.waitFor(3);
  ASSERT_EQ(more.size(), 3U);
  EXPECT_EQ(more[2].newest, 5);
  EXPECT_FALSE(more[2].replaced.has_value());
}

TEST(NewestSlot, EndWaitsForTheRunningWorkAndDropsTheWaitingInput)
{
  Recorder recorder;
  NewestSlot<int> slot("test_slot", [&](const int& newest, const std::optional<int>& replaced)
                       { recorder.work(newest, replaced); });
  slot.offer(1);
  recorder.waitFor(1);
  slot.offer(2);  // waits in the slot
  std::atomic<bool> ended{false};
  std::thread ender(
      [&]
      {
        slot.end();
        ended = true;
      });
  std::this_thread::sleep_for(std::chrono::milliseconds(50));
  EXPECT_FALSE(ended);  // the work on 1 is still running
  recorder.open();
  ender.join();
  EXPECT_TRUE(ended);
  EXPECT_FALSE(slot.offer(3));
  std::this_thread::sleep_for(std::chrono::milliseconds(50));
  const std::vector<Call> calls = recorder.waitFor(1);
  ASSERT_EQ(calls.size(), 1U);  // neither 2 nor 3 was worked on
  EXPECT_EQ(calls[0].newest, 1);
}

TEST(NewestSlot, AnExceptionOfTheWorkDropsItsInputAndTheSlotGoesOn)
{
  std::vector<int> taken;
  std::mutex mutex;
  std::condition_variable changed;
  NewestSlot<int> slot("test_slot",
                       [&](const int& newest, const std::optional<int>&)
                       {
                         std::lock_guard<std::mutex> lock(mutex);
                         taken.push_back(newest);
                         changed.notify_all();
                         if (newest == 1)
                         {
                           throw std::runtime_error("unusable input");
                         }
                       });
  slot.offer(1);
  {
    std::unique_lock<std::mutex> lock(mutex);
    ASSERT_TRUE(changed.wait_for(lock, std::chrono::seconds(5), [&] { return taken.size() == 1; }));
  }
  slot.offer(2);
  std::unique_lock<std::mutex> lock(mutex);
  ASSERT_TRUE(changed.wait_for(lock, std::chrono::seconds(5), [&] { return taken.size() == 2; }));
  EXPECT_EQ(taken, (std::vector<int>{1, 2}));
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
