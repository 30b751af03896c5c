// The newest input of a stage that is slower than its sensor: one slot instead of a queue.
#pragma once

#include <ros/callback_queue_interface.h>

#include <cstdint>
#include <functional>
#include <mutex>
#include <optional>
#include <utility>

#include "grid_vision_fusion/ros_sync/owned_callbacks.h"

namespace grid_vision_fusion
{
/// Hands a stage's inputs to its work on a callback queue (a nodelet's multi-threaded one) so that
/// the work always takes the newest input: an input that arrives while the work is busy waits in
/// the slot, and a still newer one replaces it (the older is dropped, and offer() says so) instead
/// of queueing behind it. The latency from an input's arrival to its output is then at most about
/// two processing times, whatever the input rate; the stage runs at its capacity.
///
/// `work(newest, replaced)` runs for each input taken, one call at a time; `replaced` is the
/// newest input dropped since the previous call (absent when none was), for a filter that must
/// know the input went on while it was busy. The owner's destructor calls end() before the
/// members its work uses are gone (see OwnedCallbacks).
template <typename Input>
class NewestSlot
{
public:
  using Work = std::function<void(const Input& newest, const std::optional<Input>& replaced)>;

  explicit NewestSlot(Work work) : work_(std::move(work)) {}

  /// Puts `input` in the slot and schedules the work on `queue` (under `owner_id`) unless it is
  /// already scheduled. Returns true when `input` replaced an input the work had not taken yet
  /// (that one is dropped). Returns at once. Every call must name the same queue and owner.
  bool offer(Input input, ros::CallbackQueueInterface& queue, std::uint64_t owner_id)
  {
    bool replaced = false;
    bool schedule = false;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (pending_)
      {
        replaced = true;
        replaced_ = std::move(pending_);
      }
      pending_ = std::move(input);
      schedule = !scheduled_;
      scheduled_ = true;
      queue_ = &queue;
      owner_id_ = owner_id;
    }
    if (schedule)
    {
      post();
    }
    return replaced;
  }

  /// Waits for a running work call; the slot is not served after it.
  void end() { callbacks_.end(); }

private:
  void post()
  {
    callbacks_.post(
        *queue_, [this] { workOnce(); }, owner_id_);
  }

  /// One input per callback: an input that came meanwhile is worked on in a callback posted anew,
  /// behind what the queue's threads have waiting. A loop here would keep a thread of the nodelet
  /// manager for as long as the inputs come faster than the work (overload), and the other
  /// nodelets' callbacks queued on that thread would wait for all of it.
  void workOnce()
  {
    std::optional<Input> newest;
    std::optional<Input> replaced;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      newest.swap(pending_);
      replaced.swap(replaced_);
    }
    if (newest)
    {
      work_(*newest, replaced);
    }
    bool again = false;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      again = pending_.has_value();
      scheduled_ = again;
    }
    if (again)
    {
      post();
    }
  }

  const Work work_;
  std::mutex mutex_;
  std::optional<Input> pending_;
  std::optional<Input> replaced_;
  bool scheduled_ = false;
  ros::CallbackQueueInterface* queue_ = nullptr;
  std::uint64_t owner_id_ = 0;
  OwnedCallbacks callbacks_;  // declared last: destroyed (ended) first
};

}  // namespace grid_vision_fusion
