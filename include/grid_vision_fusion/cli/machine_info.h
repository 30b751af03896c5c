// What a benchmark ran on: the CPU model, the vector extensions that decide its speed (AVX2,
// AVX-512, FMA), the cores and the clock, and the single-precision peak they give. Every
// benchmark of the package prints it, so that figures from different machines are never
// compared as if they came from one.
#pragma once

#include <string>

namespace grid_vision_fusion
{
struct MachineInfo
{
  std::string cpu_model;  ///< "model name" of /proc/cpuinfo
  int cores = 1;          ///< logical CPUs this process may run on
  double mhz = 0.0;       ///< current clock of the first CPU [MHz] ("cpu MHz")
  bool avx = false;
  bool avx2 = false;
  bool avx512f = false;
  bool fma = false;

  /// FP32 FLOP per cycle and core: 32 with AVX2 + FMA (two 256-bit FMA pipes; AVX-512 counted
  /// the same, as AMD Zen 4 runs it on those pipes), 16 with AVX (8-lane add + multiply), 8
  /// otherwise.
  int flopsPerCycle() const;
  /// cores × clock × flopsPerCycle() [GFLOP/s].
  double peakGflops() const;
  /// One line: "<model>, <n> cores at <mhz> MHz, AVX2 yes, AVX-512 no, FMA yes".
  std::string describe() const;
};

/// The machine this process runs on, from /proc/cpuinfo and the CPU affinity (fields stay at
/// their defaults where the system does not tell).
MachineInfo machineInfo();

}  // namespace grid_vision_fusion
