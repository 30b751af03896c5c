// A terminal progress bar for the command-line tools: on a terminal one line redrawn in place
// ("\r<label> [####      ] 40/108"), otherwise (a log file, a pipe) a few plain lines
// ("<label>: 27/108 (25 %)") at every quarter, so logs stay short.
#pragma once

#include <cstddef>
#include <ostream>
#include <string>

namespace grid_vision_fusion
{
class ProgressBar
{
public:
  /// `total` steps (0 is allowed: nothing to show until finish()); `interactive`: `out` is a
  /// terminal; `width`: characters between the brackets (≥ 1).
  ProgressBar(std::ostream& out, std::size_t total, std::string label, bool interactive, int width = 40);

  /// Reports `done` steps (clamped to total). Draws only when the output changes.
  void update(std::size_t done);
  /// Draws the final state and ends the line. Idempotent.
  void finish();

  /// The bar of `done` of `total` steps: "[####      ] 40/108" (width characters in brackets).
  static std::string render(std::size_t done, std::size_t total, int width);

private:
  std::ostream& out_;
  std::size_t total_;
  std::string label_;
  bool interactive_;
  int width_;
  std::size_t done_ = 0;
  std::string last_drawn_;
  int last_quarter_ = -1;
  bool finished_ = false;
};

}  // namespace grid_vision_fusion
