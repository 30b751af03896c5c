// Callbacks that a nodelet posts on a callback queue it does not own.
#pragma once

#include <ros/callback_queue_interface.h>
#include <boost/make_shared.hpp>

#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <utility>

namespace grid_vision_fusion
{
/// Posts an owner's callbacks on a ros::CallbackQueueInterface that the owner only references
/// (a nodelet's queues: at shutdown the manager may free them before it deletes the nodelet,
/// from another thread). A callback runs only while the owner lives; end() waits for a running
/// one, and the ones still queued then do nothing. The queue is not touched after post(), so
/// the owner's destructor must not remove its callbacks from it: it calls end().
class OwnedCallbacks
{
public:
  OwnedCallbacks() = default;
  ~OwnedCallbacks() { end(); }
  OwnedCallbacks(const OwnedCallbacks&) = delete;
  OwnedCallbacks& operator=(const OwnedCallbacks&) = delete;

  /// Adds `function` to `queue` under `owner_id`; it runs if end() has not been called by then.
  void post(ros::CallbackQueueInterface& queue, std::function<void()> function, std::uint64_t owner_id) const
  {
    queue.addCallback(boost::make_shared<Callback>(state_, std::move(function)), owner_id);
  }

  /// Waits for a running callback; the ones still queued will do nothing. The owner's destructor
  /// calls it first, before the members its callbacks use are gone.
  void end()
  {
    std::lock_guard<std::mutex> lock(state_->mutex);
    state_->alive = false;
  }

private:
  struct State
  {
    std::mutex mutex;  // held by a running callback
    bool alive = true;
  };

  class Callback : public ros::CallbackInterface
  {
  public:
    Callback(std::shared_ptr<State> state, std::function<void()> function)
        : state_(std::move(state)), function_(std::move(function))
    {
    }
    CallResult call() override
    {
      std::lock_guard<std::mutex> lock(state_->mutex);
      if (state_->alive)
      {
        function_();
      }
      return Success;
    }

  private:
    const std::shared_ptr<State> state_;
    const std::function<void()> function_;
  };

  const std::shared_ptr<State> state_ = std::make_shared<State>();
};

}  // namespace grid_vision_fusion
