// The interval at which a stream's messages come, by their stamps.
#pragma once

#include <ros/time.h>

#include <algorithm>
#include <array>
#include <cstddef>
#include <mutex>

namespace grid_vision_fusion
{
/// How far apart a stream's messages come, by their stamps: the second longest of the last
/// kIntervals intervals. It covers the spread of a stream that comes irregularly (a stage slower
/// than its input delivers in bursts and pauses) and ignores one long gap (an outage, a bag
/// paused); when the stream stops it keeps its value from before, so that the silence itself can
/// be told from it. A stamp before the previous one (time went backwards: a bag loop) starts over.
/// Thread-safe.
///
/// The grid_projection nodelet reads it for the grids: a grid stage slower than its lidar
/// (overload) delivers grids further apart in sensor time than the scans come, and the newest
/// grid there is at an image's time is then about two such intervals old, more during a slow
/// cycle (ProjectionStage::maxGridAge()).
class StampCadence
{
public:
  static constexpr std::size_t kIntervals = 5;

  void add(const ros::Time& stamp)
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (has_last_ && stamp < last_)
    {
      restart();
    }
    if (has_last_)
    {
      intervals_[next_] = (stamp - last_).toSec();
      next_ = (next_ + 1) % kIntervals;
      filled_ = std::min(filled_ + 1, kIntervals);
    }
    last_ = stamp;
    has_last_ = true;
  }

  /// The second longest of the last intervals (the only one while there is one) [s]; 0 before two
  /// stamps.
  double interval() const
  {
    std::lock_guard<std::mutex> lock(mutex_);
    double longest = 0.0;
    double second = 0.0;
    for (std::size_t i = 0; i < filled_; ++i)
    {
      second = std::max(second, std::min(longest, intervals_[i]));
      longest = std::max(longest, intervals_[i]);
    }
    return filled_ == 1 ? longest : second;
  }

  void clear()
  {
    std::lock_guard<std::mutex> lock(mutex_);
    restart();
  }

private:
  void restart()
  {
    has_last_ = false;
    filled_ = 0;
    next_ = 0;
  }

  mutable std::mutex mutex_;
  std::array<double, kIntervals> intervals_{};
  std::size_t filled_ = 0;  // intervals held
  std::size_t next_ = 0;    // where the next interval goes
  bool has_last_ = false;
  ros::Time last_;
};

}  // namespace grid_vision_fusion
