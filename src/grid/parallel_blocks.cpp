#include "grid_vision_fusion/grid/parallel_blocks.h"

#include <tbb/info.h>

#include <algorithm>

namespace grid_vision_fusion
{
ParallelBlocks::ParallelBlocks(int threads)
    : threads_(threads > 0 ? threads : std::max(1, static_cast<int>(tbb::info::default_concurrency())))
{
  if (threads_ > 1)
  {
    arena_ = std::make_unique<tbb::task_arena>(threads_);
  }
}

}  // namespace grid_vision_fusion
