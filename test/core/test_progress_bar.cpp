// Tests of the progress bar's output to a file (no terminal: plain lines at 25 % steps).
#include <gtest/gtest.h>

#include <cstdio>
#include <string>

#include "grid_vision_fusion/core/progress_bar.h"

namespace grid_vision_fusion
{
TEST(ProgressBar, PlainLinesWithoutATerminal)
{
  std::FILE* file = std::tmpfile();
  ASSERT_NE(file, nullptr);
  {
    ProgressBar bar("frames", 8, file);
    for (std::size_t i = 1; i <= 8; ++i)
    {
      bar.update(i);
    }
    bar.finish();
    bar.finish();  // idempotent
  }
  std::rewind(file);
  std::string text;
  char buffer[256];
  while (std::fgets(buffer, sizeof(buffer), file))
  {
    text += buffer;
  }
  std::fclose(file);
  // 2/8 = 25 %, 4/8, 6/8, 8/8: four lines, no carriage returns.
  EXPECT_EQ(std::count(text.begin(), text.end(), '\n'), 4) << text;
  EXPECT_EQ(text.find('\r'), std::string::npos);
  EXPECT_NE(text.find("[###############               ] 4/8 frames"), std::string::npos) << text;
  EXPECT_NE(text.find("[##############################] 8/8 frames"), std::string::npos) << text;
}

}  // namespace grid_vision_fusion
