// Which grid the grid_projection nodelet projects into an image: the grid of the image's own
// lidar sweep, also when that grid is still being computed as the camera_info arrives.
#pragma once

#include <ros/time.h>
#include <boost/shared_ptr.hpp>

#include <cstddef>
#include <deque>
#include <mutex>
#include <vector>

namespace grid_vision_fusion
{
/// Pairs each camera_info with a grid as run_pipeline's stamp order does: the newest grid stamped
/// at or before the image (else the oldest grid kept, the nearest after it).
///
/// In a live chain (or a bag played at its rate) a sweep's cloud and its image arrive together,
/// and the grid of that sweep comes out of the filter some 10 ms later: projecting the newest
/// grid at once would project the previous sweep's, moved forward by its velocities. So a
/// camera_info waits while the newest grid received is stamped more than `tolerance` before it,
/// until a grid within `tolerance` (or after it) arrives, or until the next camera_info does (the
/// lidar is a whole frame late, or silent): then the waiting one takes what is there. Before the
/// first grid there is nothing to take, and the first grid is the slowest (the filter starts, the
/// tf of the first scan may come late): camera_infos wait for it, the oldest given up (with no
/// grid) only when more than kMaxWaitingForFirstGrid wait. A negative tolerance never waits. A
/// grid stamped before the newest kept one (time went backwards: a bag loop) pairs the waiting
/// camera_infos with the old grids, then replaces them. Thread-safe.
template <typename Grid, typename Info>
class GridForImage
{
public:
  using GridPtr = boost::shared_ptr<const Grid>;
  using InfoPtr = boost::shared_ptr<const Info>;

  /// A camera_info and its grid; `grid` is empty when no grid had been received at all.
  struct Pair
  {
    InfoPtr info;
    GridPtr grid;
  };

  /// Most camera_infos that wait for the first grid: a second of images at 10 Hz.
  static constexpr std::size_t kMaxWaitingForFirstGrid = 10;

  /// `tolerance_s` finite [s]; `grids_kept` >= 1 most recent grids are candidates.
  explicit GridForImage(double tolerance_s, std::size_t grids_kept = 4)
      : tolerance_(tolerance_s < 0.0 ? -1.0 : tolerance_s), grids_kept_(grids_kept < 1 ? 1 : grids_kept)
  {
  }

  /// The camera_infos paired now, in arrival order: those that were waiting, then `info` unless
  /// it has to wait for its grid.
  std::vector<Pair> addInfo(const InfoPtr& info)
  {
    std::lock_guard<std::mutex> lock(mutex_);
    std::vector<Pair> out;
    if (grids_.empty() && tolerance_ >= 0.0)
    {
      waiting_.push_back(info);
      while (waiting_.size() > kMaxWaitingForFirstGrid)
      {
        out.push_back({waiting_.front(), GridPtr()});
        waiting_.pop_front();
      }
      return out;
    }
    pairAllWaiting(out);
    if (complete(info->header.stamp))
    {
      out.push_back({info, chooseFor(info->header.stamp)});
    }
    else
    {
      waiting_.push_back(info);
    }
    return out;
  }

  /// The waiting camera_infos paired now that `grid` is there, in arrival order.
  std::vector<Pair> addGrid(const GridPtr& grid)
  {
    std::lock_guard<std::mutex> lock(mutex_);
    std::vector<Pair> out;
    if (!grids_.empty() && grid->header.stamp < grids_.back()->header.stamp)
    {
      pairAllWaiting(out);
      grids_.clear();
    }
    grids_.push_back(grid);
    while (grids_.size() > grids_kept_)
    {
      grids_.pop_front();
    }
    while (!waiting_.empty() && complete(waiting_.front()->header.stamp))
    {
      out.push_back({waiting_.front(), chooseFor(waiting_.front()->header.stamp)});
      waiting_.pop_front();
    }
    return out;
  }

  /// The newest grid received (empty before the first).
  GridPtr newestGrid() const
  {
    std::lock_guard<std::mutex> lock(mutex_);
    return grids_.empty() ? GridPtr() : grids_.back();
  }

  /// camera_infos waiting for their grid.
  std::size_t waiting() const
  {
    std::lock_guard<std::mutex> lock(mutex_);
    return waiting_.size();
  }

  /// Forgets the grids and the waiting camera_infos.
  void clear()
  {
    std::lock_guard<std::mutex> lock(mutex_);
    grids_.clear();
    waiting_.clear();
  }

private:
  /// Under mutex_: every waiting camera_info, with the best grid there is, appended to `out`.
  void pairAllWaiting(std::vector<Pair>& out)
  {
    for (const InfoPtr& waiting : waiting_)
    {
      out.push_back({waiting, chooseFor(waiting->header.stamp)});
    }
    waiting_.clear();
  }

  /// Under mutex_: the grid of the sweep at `stamp` has arrived (or no waiting is wanted).
  bool complete(const ros::Time& stamp) const
  {
    if (tolerance_ < 0.0)
    {
      return true;
    }
    return !grids_.empty() && (grids_.back()->header.stamp - stamp).toSec() >= -tolerance_ - 1e-9;
  }

  /// Under mutex_: the newest grid stamped at or before `stamp`, else the oldest kept.
  GridPtr chooseFor(const ros::Time& stamp) const
  {
    GridPtr chosen;
    for (const GridPtr& grid : grids_)
    {
      if (grid->header.stamp <= stamp)
      {
        chosen = grid;
      }
    }
    return chosen || grids_.empty() ? chosen : grids_.front();
  }

  const double tolerance_;
  const std::size_t grids_kept_;
  mutable std::mutex mutex_;
  std::deque<GridPtr> grids_;  // oldest first, stamps ascending
  std::deque<InfoPtr> waiting_;
};

}  // namespace grid_vision_fusion
