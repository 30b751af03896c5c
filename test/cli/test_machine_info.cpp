// The machine description the benchmarks print.
#include <gtest/gtest.h>

#include "grid_vision_fusion/cli/machine_info.h"

namespace grid_vision_fusion
{
namespace
{
TEST(MachineInfo, ReadsThisMachine)
{
  const MachineInfo info = machineInfo();
  EXPECT_GE(info.cores, 1);
  EXPECT_FALSE(info.cpu_model.empty()) << "no model name in /proc/cpuinfo";
  EXPECT_GT(info.mhz, 0.0);
  EXPECT_NE(info.describe().find(info.cpu_model), std::string::npos);
}

TEST(MachineInfo, PeakFollowsTheVectorUnits)
{
  MachineInfo info;
  info.cores = 2;
  info.mhz = 2000.0;
  EXPECT_EQ(info.flopsPerCycle(), 8);
  info.avx = true;
  EXPECT_EQ(info.flopsPerCycle(), 16);
  info.avx2 = true;
  info.fma = true;
  EXPECT_EQ(info.flopsPerCycle(), 32);
  EXPECT_DOUBLE_EQ(info.peakGflops(), 128.0);
  info.avx512f = true;
  EXPECT_NE(info.describe().find("AVX-512 yes"), std::string::npos) << info.describe();
}

}  // namespace
}  // namespace grid_vision_fusion
