#include "grid_vision_fusion/core/progress_bar.h"

#include <unistd.h>

#include <algorithm>

namespace grid_vision_fusion
{
namespace
{
constexpr int kBarWidth = 30;
constexpr int kPlainLinePercentStep = 25;  // without a terminal: a line at 0, 25, 50, 75, 100 %
}  // namespace

ProgressBar::ProgressBar(std::string label, std::size_t total, std::FILE* stream)
  : label_(std::move(label))
  , total_(std::max<std::size_t>(total, 1))
  , stream_(stream)
  , terminal_(isatty(fileno(stream)) != 0)
  , start_(std::chrono::steady_clock::now())
{
}

void ProgressBar::update(std::size_t done)
{
  done = std::min(done, total_);
  if (terminal_)
  {
    if (done != last_drawn_ || done == 0)
    {
      draw(done, false);
    }
    return;
  }
  const int percent = static_cast<int>(100 * done / total_);
  if (percent / kPlainLinePercentStep > last_percent_line_)
  {
    last_percent_line_ = percent / kPlainLinePercentStep;
    draw(done, true);
  }
}

void ProgressBar::finish()
{
  if (finished_)
  {
    return;
  }
  finished_ = true;
  if (terminal_ || last_percent_line_ < 100 / kPlainLinePercentStep)
  {
    draw(total_, true);
  }
}

void ProgressBar::draw(std::size_t done, bool final_line)
{
  last_drawn_ = done;
  const double elapsed =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  const int filled = static_cast<int>(kBarWidth * done / total_);
  const std::string bar = std::string(static_cast<std::size_t>(filled), '#') +
                          std::string(static_cast<std::size_t>(kBarWidth - filled), ' ');
  const double rate = elapsed > 0.0 ? static_cast<double>(done) / elapsed : 0.0;
  const double remaining = rate > 0.0 ? static_cast<double>(total_ - done) / rate : 0.0;
  std::fprintf(stream_, "%s[%s] %zu/%zu %s  %.1f s elapsed, %.1f s left%s", terminal_ ? "\r" : "", bar.c_str(), done,
               total_, label_.c_str(), elapsed, remaining, final_line || !terminal_ ? "\n" : "");
  std::fflush(stream_);
}

}  // namespace grid_vision_fusion
