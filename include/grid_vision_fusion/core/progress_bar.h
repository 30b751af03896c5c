// A terminal progress bar for the long-running tools: redrawn in place on a terminal, a few
// plain lines when the output is a file or a pipe (CI logs).
#pragma once

#include <chrono>
#include <cstdio>
#include <string>

namespace grid_vision_fusion
{
/// Progress of `total` steps, written to a stdio stream (stderr by default).
class ProgressBar
{
public:
  /// @param label what is counted, e.g. "frames"; @param total number of steps, > 0.
  ProgressBar(std::string label, std::size_t total, std::FILE* stream = stderr);
  /// Reports that `done` steps are complete (monotonic); redraws when useful.
  void update(std::size_t done);
  /// Draws the final state and ends the line.
  void finish();

private:
  void draw(std::size_t done, bool final_line);

  std::string label_;
  std::size_t total_;
  std::FILE* stream_;
  bool terminal_;
  std::size_t last_drawn_ = 0;
  int last_percent_line_ = 0;  // without a terminal: the last 25 % step drawn
  bool finished_ = false;
  std::chrono::steady_clock::time_point start_;
};

}  // namespace grid_vision_fusion
