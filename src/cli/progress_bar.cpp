#include "grid_vision_fusion/cli/progress_bar.h"

#include <algorithm>
#include <stdexcept>

namespace grid_vision_fusion
{
ProgressBar::ProgressBar(std::ostream& out, std::size_t total, std::string label, bool interactive, int width)
    : out_(out), total_(total), label_(std::move(label)), interactive_(interactive), width_(width)
{
  if (width_ < 1)
  {
    throw std::invalid_argument("progress bar width must be >= 1, got " + std::to_string(width_));
  }
}

std::string ProgressBar::render(std::size_t done, std::size_t total, int width)
{
  done = std::min(done, total);
  const std::size_t w = static_cast<std::size_t>(std::max(width, 1));
  const std::size_t filled = total == 0 ? w : done * w / total;
  return "[" + std::string(filled, '#') + std::string(w - filled, ' ') + "] " + std::to_string(done) + "/" +
         std::to_string(total);
}

void ProgressBar::update(std::size_t done)
{
  if (finished_)
  {
    return;
  }
  done_ = std::min(done, total_);
  if (interactive_)
  {
    const std::string line = label_ + " " + render(done_, total_, width_);
    if (line != last_drawn_)
    {
      out_ << '\r' << line << std::flush;
      last_drawn_ = line;
    }
    return;
  }
  const int quarter = total_ == 0 ? 4 : static_cast<int>(done_ * 4 / total_);
  if (quarter != last_quarter_)
  {
    out_ << label_ << ": " << done_ << "/" << total_ << " (" << (total_ == 0 ? 100 : done_ * 100 / total_)
         << " %)\n"
         << std::flush;
    last_quarter_ = quarter;
  }
}

void ProgressBar::finish()
{
  if (finished_)
  {
    return;
  }
  update(total_);
  finished_ = true;
  if (interactive_)
  {
    out_ << '\n' << std::flush;
  }
}

}  // namespace grid_vision_fusion
