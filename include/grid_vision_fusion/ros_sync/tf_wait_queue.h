// Messages that wait for the tf of their stamp before a nodelet uses them.
#pragma once

#include <ros/callback_queue_interface.h>
#include <ros/node_handle.h>
#include <ros/time.h>
#include <tf2/buffer_core.h>
#include <boost/shared_ptr.hpp>

#include <algorithm>
#include <atomic>
#include <cstdint>
#include <deque>
#include <functional>
#include <mutex>
#include <string>
#include <utility>
#include <vector>

#include "grid_vision_fusion/ros_sync/owned_callbacks.h"

namespace grid_vision_fusion
{
/// How often TfWaitPolling polls besides TfWaitWakeup's polls [s].
constexpr double kTfWaitPollS = 0.1;

/// Why TfWaitQueue gave a message up.
enum class TfWaitDrop : std::uint8_t
{
  kEmptyFrameId = 0,  ///< the message names no frame
  kQueueFull = 1,     ///< `capacity` newer messages arrived while its tf did not
};

/// Frames joined by spaces, for messages.
inline std::string joinFrames(const std::vector<std::string>& frames)
{
  std::string joined;
  for (const std::string& frame : frames)
  {
    joined += (joined.empty() ? "" : " ") + frame;
  }
  return joined;
}

/// The messages (with a std_msgs/Header `header`) waiting for the tf from their frame to every
/// target frame at their stamp (the queue's, or each message's own: `frames_of`), in arrival
/// order: what tf2_ros::MessageFilter does, without its lost wake-up. MessageFilter::add()
/// registers a message's transform request with the buffer before it puts the message in its
/// queue; a transform that arrives in between fires the request while the message is not there,
/// and the message then waits until the queue overflows (tf2_ros 0.7, message_filter.h). This
/// queue registers nothing: it asks the buffer (canTransform) when a message arrives and on every
/// poll(), which its owner calls when the buffer receives transforms and from a timer
/// (TfWaitPolling).
/// Thread-safe; `ready` and `dropped` are called one at a time, without the queue's lock held
/// (they may call setTargetFrames(), targetFramesString(), size(), clear(), not add() or poll()).
template <typename M>
class TfWaitQueue
{
public:
  using ConstPtr = boost::shared_ptr<const M>;
  using Ready = std::function<void(const ConstPtr&)>;
  using Dropped = std::function<void(const ConstPtr&, TfWaitDrop)>;
  /// The target frames of one message, where they depend on the message.
  using FramesOf = std::function<std::vector<std::string>(const M&)>;

  /// `capacity` >= 1 messages wait at most. With `frames_of`, each message waits for the tf to
  /// its own target frames and setTargetFrames() is not used.
  TfWaitQueue(const tf2::BufferCore& buffer, std::size_t capacity, Ready ready, Dropped dropped,
              FramesOf frames_of = nullptr)
      : buffer_(buffer),
        capacity_(std::max<std::size_t>(capacity, 1)),
        ready_(std::move(ready)),
        dropped_(std::move(dropped)),
        frames_of_(std::move(frames_of))
  {
  }

  /// The frames every message needs a tf to (none: every message goes on at once).
  void setTargetFrames(std::vector<std::string> frames)
  {
    std::lock_guard<std::mutex> lock(mutex_);
    frames_ = std::move(frames);
  }

  /// The target frames joined by spaces, for messages.
  std::string targetFramesString() const
  {
    std::lock_guard<std::mutex> lock(mutex_);
    return joinFrames(frames_);
  }

  /// Passes `msg` on (with the queued ones whose tf has arrived meanwhile) when its tf is there,
  /// queues it otherwise; the oldest waiting message is dropped when `capacity` wait already.
  void add(const ConstPtr& msg)
  {
    std::lock_guard<std::mutex> serial(release_mutex_);
    if (msg->header.frame_id.empty())
    {
      dropped_(msg, TfWaitDrop::kEmptyFrameId);
      return;
    }
    ConstPtr overflow;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      queue_.push_back(msg);
      if (queue_.size() > capacity_)
      {
        overflow = queue_.front();
        queue_.pop_front();
      }
    }
    if (overflow)
    {
      dropped_(overflow, TfWaitDrop::kQueueFull);
    }
    release();
  }

  /// Passes on, in arrival order, every waiting message whose tf has arrived.
  void poll()
  {
    std::lock_guard<std::mutex> serial(release_mutex_);
    release();
  }

  /// Forgets the waiting messages (not reported as dropped).
  void clear()
  {
    std::lock_guard<std::mutex> lock(mutex_);
    queue_.clear();
  }

  /// Messages waiting.
  std::size_t size() const
  {
    std::lock_guard<std::mutex> lock(mutex_);
    return queue_.size();
  }

private:
  /// Takes the messages whose tf is there out of the queue, then passes them on.
  /// Under release_mutex_.
  void release()
  {
    std::vector<ConstPtr> ready;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      for (auto it = queue_.begin(); it != queue_.end();)
      {
        if (transformable(**it))
        {
          ready.push_back(*it);
          it = queue_.erase(it);
        }
        else
        {
          ++it;
        }
      }
    }
    for (const ConstPtr& msg : ready)
    {
      ready_(msg);
    }
  }

  /// Under mutex_.
  bool transformable(const M& msg) const
  {
    for (const std::string& frame : frames_of_ ? frames_of_(msg) : frames_)
    {
      if (!buffer_.canTransform(frame, msg.header.frame_id, msg.header.stamp))
      {
        return false;
      }
    }
    return true;
  }

  const tf2::BufferCore& buffer_;
  const std::size_t capacity_;
  const Ready ready_;
  const Dropped dropped_;
  const FramesOf frames_of_;
  mutable std::mutex mutex_;  // queue_, frames_
  std::mutex release_mutex_;  // one add() or poll() at a time: the callbacks in order
  std::deque<ConstPtr> queue_;
  std::vector<std::string> frames_;
};

/// Calls `poll` on `callbacks` (a node's callback queue: where tf2_ros::MessageFilter hands its
/// ready messages too) each time `buffer` receives transforms, one call pending at most.
class TfWaitWakeup
{
public:
  TfWaitWakeup(tf2::BufferCore& buffer, ros::CallbackQueueInterface& callbacks, std::function<void()> poll)
      : buffer_(buffer), callbacks_(callbacks), poll_(std::move(poll))
  {
    connection_ = buffer_._addTransformsChangedListener([this] { wake(); });
  }
  /// Waits for a running poll; a poll still queued does nothing (OwnedCallbacks).
  ~TfWaitWakeup()
  {
    buffer_._removeTransformsChangedListener(connection_);
    polls_.end();
  }
  TfWaitWakeup(const TfWaitWakeup&) = delete;
  TfWaitWakeup& operator=(const TfWaitWakeup&) = delete;

private:
  void wake()
  {
    if (!pending_.exchange(true))
    {
      polls_.post(
          callbacks_,
          [this]
          {
            pending_.store(false);
            poll_();
          },
          reinterpret_cast<std::uint64_t>(this));
    }
  }

  tf2::BufferCore& buffer_;
  ros::CallbackQueueInterface& callbacks_;
  const std::function<void()> poll_;
  std::atomic<bool> pending_{false};
  OwnedCallbacks polls_;
  boost::signals2::connection connection_;
};

/// What polls a nodelet's TfWaitQueue: TfWaitWakeup on the node's callback queue whenever tf
/// arrives, and a wall timer every kTfWaitPollS, for the messages whose tf was there already
/// when the target frames changed. Declare it after the queue (it is destroyed first).
class TfWaitPolling
{
public:
  TfWaitPolling(tf2::BufferCore& buffer, ros::NodeHandle& nh, const std::function<void()>& poll)
      : wakeup_(buffer, *nh.getCallbackQueue(), poll),
        timer_(nh.createWallTimer(ros::WallDuration(kTfWaitPollS),
                                  [poll](const ros::WallTimerEvent&) { poll(); }))
  {
  }

private:
  TfWaitWakeup wakeup_;
  ros::WallTimer timer_;
};

}  // namespace grid_vision_fusion
