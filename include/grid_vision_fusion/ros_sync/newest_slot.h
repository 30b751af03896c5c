// The newest input of a stage that is slower than its sensor: one slot instead of a queue, worked
// on by a thread of the stage's own.
#pragma once

#include <pthread.h>
#include <ros/console.h>
#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <condition_variable>
#include <exception>
#include <functional>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <utility>

namespace grid_vision_fusion
{
/// Hands a stage's inputs to its work on a thread of its own, so that the work always takes the
/// newest input: an input that arrives while the work is busy waits in the slot, and a still newer
/// one replaces it (the older is dropped, and offer() says so) instead of queueing behind it. The
/// latency from an input's arrival to its output is then at most about two processing times,
/// whatever the input rate; the stage runs at its capacity.
///
/// Why a thread of its own, and a nicer one: the nodelet manager hands each callback to one of its
/// worker threads, which runs the callbacks handed to it one after the other, so a grid cycle or an
/// inference (tens of milliseconds, more under load) on a manager thread held up the short
/// callbacks of the projection and the fusion queued behind it, frames at a time. On a thread of
/// its own the long work is preempted by the kernel instead, and at nice +10 (kNiceIncrement) it
/// yields the cores to those callbacks whenever they can run and takes what is left. At rate 15
/// (scripts/soak.sh) the p99 latency from a frame's arrival to its objects went from 0.12-0.14 s
/// to 0.04-0.09 s, against 0.05-0.07 s at rate 1 (doc/decisions/0026-stage-threads.md).
///
/// `work(newest, replaced)` runs for each input taken, one call at a time, on the slot's thread;
/// an exception it throws is logged and its input dropped. `replaced` is the newest input dropped
/// since the previous call (absent when none was), for a filter that must know the input went on
/// while it was busy. The owner calls end() (or destroys the slot) before the members its work
/// uses are gone.
template <typename Input>
class NewestSlot
{
public:
  using Work = std::function<void(const Input& newest, const std::optional<Input>& replaced)>;

  /// Starts the slot's thread; `name` (at most 15 characters) names it in top -H, gdb and perf.
  NewestSlot(const std::string& name, Work work)
      : name_(name), work_(std::move(work)), thread_([this] { run(); })
  {
    pthread_setname_np(thread_.native_handle(), name_.substr(0, 15).c_str());
  }

  NewestSlot(const NewestSlot&) = delete;
  NewestSlot& operator=(const NewestSlot&) = delete;

  ~NewestSlot() { end(); }

  /// Puts `input` in the slot for the work and returns at once. Returns true when `input` replaced
  /// an input the work had not taken yet (that one is dropped). After end(), does nothing.
  bool offer(Input input)
  {
    bool replaced = false;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (ended_)
      {
        return false;
      }
      if (pending_)
      {
        replaced = true;
        replaced_ = std::move(pending_);
      }
      pending_ = std::move(input);
    }
    wake_.notify_one();
    return replaced;
  }

  /// Waits for a running work call and stops the thread; an input still in the slot is not worked
  /// on. Called by the owner's thread (not by the work).
  void end()
  {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      ended_ = true;
      pending_.reset();
      replaced_.reset();
    }
    wake_.notify_one();
    if (thread_.joinable())
    {
      thread_.join();
    }
  }

  /// How much nicer than the thread that made the slot its thread runs (Linux nice values).
  static constexpr int kNiceIncrement = 10;

private:
  /// The slot's thread yields the cores to the short callbacks of the manager's threads.
  void lowerPriority()
  {
    const auto thread_id = static_cast<id_t>(syscall(SYS_gettid));
    errno = 0;
    const int nice = getpriority(PRIO_PROCESS, thread_id);  // inherited from the creating thread
    if (errno == 0 && setpriority(PRIO_PROCESS, thread_id, std::min(nice + kNiceIncrement, 19)) != 0)
    {
      ROS_WARN("%s: cannot lower the priority of its thread (nice %d): it competes with the other stages",
               name_.c_str(), nice);
    }
  }

  void run()
  {
    lowerPriority();
    std::unique_lock<std::mutex> lock(mutex_);
    while (true)
    {
      wake_.wait(lock, [this] { return ended_ || pending_.has_value(); });
      if (ended_)
      {
        return;
      }
      std::optional<Input> newest;
      std::optional<Input> replaced;
      newest.swap(pending_);
      replaced.swap(replaced_);
      lock.unlock();
      try
      {
        work_(*newest, replaced);
      }
      catch (const std::exception& e)  // a thread's exception would end the nodelet manager
      {
        ROS_ERROR("%s: the work on an input failed, the input is dropped: %s", name_.c_str(), e.what());
      }
      newest.reset();  // the inputs are let go of outside the lock
      replaced.reset();
      lock.lock();
    }
  }

  const std::string name_;
  const Work work_;
  std::mutex mutex_;
  std::condition_variable wake_;
  std::optional<Input> pending_;
  std::optional<Input> replaced_;
  bool ended_ = false;
  std::thread thread_;  // declared last: started once the members above are there
};

}  // namespace grid_vision_fusion
