// Tests of the command-line progress bar.
#include <gtest/gtest.h>

#include <sstream>

#include "grid_vision_fusion/cli/progress_bar.h"

namespace grid_vision_fusion
{
TEST(ProgressBar, RendersTheFilledFraction)
{
  EXPECT_EQ(ProgressBar::render(0, 108, 10), "[          ] 0/108");
  EXPECT_EQ(ProgressBar::render(43, 108, 10), "[###       ] 43/108");  // 430/108 = 3.98 → 3
  EXPECT_EQ(ProgressBar::render(108, 108, 10), "[##########] 108/108");
  EXPECT_EQ(ProgressBar::render(500, 108, 4), "[####] 108/108");  // clamped
  EXPECT_EQ(ProgressBar::render(0, 0, 4), "[####] 0/0");
}

TEST(ProgressBar, TerminalRedrawsOneLineOnlyWhenItChanges)
{
  std::ostringstream out;
  ProgressBar bar(out, 4, "frames", true, 4);
  bar.update(1);
  bar.update(1);
  bar.update(2);
  bar.finish();
  bar.finish();
  EXPECT_EQ(out.str(), "\rframes [#   ] 1/4\rframes [##  ] 2/4\rframes [####] 4/4\n");
}

TEST(ProgressBar, PlainOutputPrintsAtEveryQuarter)
{
  std::ostringstream out;
  ProgressBar bar(out, 8, "frames", false);
  for (std::size_t i = 0; i <= 8; ++i)
  {
    bar.update(i);
  }
  bar.finish();
  EXPECT_EQ(out.str(),
            "frames: 0/8 (0 %)\nframes: 2/8 (25 %)\nframes: 4/8 (50 %)\nframes: 6/8 (75 %)\n"
            "frames: 8/8 (100 %)\n");
}

TEST(ProgressBar, RejectsAZeroWidth)
{
  std::ostringstream out;
  EXPECT_THROW(ProgressBar(out, 1, "x", true, 0), std::invalid_argument);
}

}  // namespace grid_vision_fusion
