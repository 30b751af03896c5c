#include "grid_vision_fusion/cli/machine_info.h"

#include <sched.h>

#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <thread>

namespace grid_vision_fusion
{
int MachineInfo::flopsPerCycle() const
{
  if (avx2 && fma)
  {
    return 32;
  }
  return avx ? 16 : 8;
}

double MachineInfo::peakGflops() const
{
  return cores * mhz / 1000.0 * flopsPerCycle();
}

std::string MachineInfo::describe() const
{
  char clock[32];
  std::snprintf(clock, sizeof(clock), "%.0f", mhz);
  std::ostringstream out;
  out << cpu_model << ", " << cores << " cores at " << clock << " MHz, AVX2 " << (avx2 ? "yes" : "no")
      << ", AVX-512 " << (avx512f ? "yes" : "no") << ", FMA " << (fma ? "yes" : "no");
  return out.str();
}

MachineInfo machineInfo()
{
  MachineInfo info;
  cpu_set_t set;
  CPU_ZERO(&set);
  info.cores = sched_getaffinity(0, sizeof(set), &set) == 0
                   ? CPU_COUNT(&set)
                   : static_cast<int>(std::thread::hardware_concurrency());
  std::ifstream cpuinfo("/proc/cpuinfo");
  std::string flags;
  for (std::string line; std::getline(cpuinfo, line);)
  {
    const auto colon = line.find(':');
    if (colon == std::string::npos || colon == 0)
    {
      continue;
    }
    const std::string key = line.substr(0, line.find_last_not_of(" \t", colon - 1) + 1);
    const std::string value = colon + 2 <= line.size() ? line.substr(colon + 2) : "";
    if (key == "model name" && info.cpu_model.empty())
    {
      info.cpu_model = value;
    }
    else if (key == "cpu MHz" && info.mhz == 0.0)
    {
      info.mhz = std::atof(value.c_str());
    }
    else if (key == "flags" && flags.empty())
    {
      flags = " " + value + " ";
    }
  }
  info.avx = flags.find(" avx ") != std::string::npos;
  info.avx2 = flags.find(" avx2 ") != std::string::npos;
  info.avx512f = flags.find(" avx512f ") != std::string::npos;
  info.fma = flags.find(" fma ") != std::string::npos;
  return info;
}

}  // namespace grid_vision_fusion
