// Benchmark of projectGrid(): the default KITTI grid (300 × 300 cells of 0.2 m, 60 m square, its
// centre 15 m ahead of the velodyne) into KITTI colour camera 2 (1242 × 375, 2011_09_26 P_rect_02
// and R_rect_00 · Tr_velo_to_cam written out below, so the benchmark needs no data file).
// Not a test: run `rosrun grid_vision_fusion bench_grid_projection`.
#include <benchmark/benchmark.h>

#include <random>
#include <vector>

#include "grid_vision_fusion/cli/machine_info.h"
#include "grid_vision_fusion/projection/grid_projection.h"

namespace grid_vision_fusion
{
namespace
{
constexpr std::uint32_t kCells = 300;
constexpr double kResolution = 0.2;

struct BenchGrid
{
  std::vector<float> p_static, p_dynamic, vx, vy;
  GridCellsView view;

  /// `occupied_fraction` of the cells occupied (half of them dynamic at 5 m/s), the rest free.
  explicit BenchGrid(double occupied_fraction)
      : p_static(kCells * kCells), p_dynamic(kCells * kCells), vx(kCells * kCells), vy(kCells * kCells)
  {
    std::mt19937 random(42);
    std::uniform_real_distribution<double> uniform(0.0, 1.0);
    for (std::size_t i = 0; i < p_static.size(); ++i)
    {
      const bool occupied = uniform(random) < occupied_fraction;
      const bool dynamic = uniform(random) < 0.5;
      p_static[i] = occupied && !dynamic ? 0.8F : 0.02F;
      p_dynamic[i] = occupied && dynamic ? 0.8F : 0.02F;
      vx[i] = dynamic ? 5.F : 0.F;
      vy[i] = dynamic ? -1.F : 0.F;
    }
    view.width = kCells;
    view.height = kCells;
    view.resolution = kResolution;
    view.origin_x = 15.0 - 30.0;  // centre 15 m ahead
    view.origin_y = -30.0;
    view.p_static = p_static.data();
    view.p_dynamic = p_dynamic.data();
    view.vx = vx.data();
    view.vy = vy.data();
  }
};

PinholeCamera kittiCamera()
{
  Eigen::Matrix<double, 3, 4> p;
  p << 7.215377e+02, 0.0, 6.095593e+02, 4.485728e+01, 0.0, 7.215377e+02, 1.728540e+02, 2.163791e-01, 0.0, 0.0,
      1.0, 2.745884e-03;
  return PinholeCamera(p, 1242, 375);
}

ProjectionGeometry kittiGeometry()
{
  Eigen::Matrix3d r_rect;
  r_rect << 9.999239e-01, 9.837760e-03, -7.445048e-03, -9.869795e-03, 9.999421e-01, -4.278459e-03,
      7.402527e-03, 4.351614e-03, 9.999631e-01;
  Eigen::Isometry3d velo_to_cam = Eigen::Isometry3d::Identity();
  velo_to_cam.linear() << 7.533745e-03, -9.999714e-01, -6.166020e-04, 1.480249e-02, 7.280733e-04,
      -9.998902e-01, 9.998621e-01, 7.523790e-03, 1.480755e-02;
  velo_to_cam.translation() << -4.069766e-03, -7.631618e-02, -2.717806e-01;
  Eigen::Isometry3d rect = Eigen::Isometry3d::Identity();
  rect.linear() = r_rect;
  ProjectionGeometry geometry;
  geometry.camera_from_grid = rect * velo_to_cam;
  geometry.ground_z = -1.73;
  geometry.time_offset = 0.05;
  return geometry;
}

/// Argument 0: occupied cells in percent; argument 1: column mode off (0) or on (1, 3 points).
void BM_ProjectGrid(benchmark::State& state)
{
  const BenchGrid grid(static_cast<double>(state.range(0)) / 100.0);
  const PinholeCamera camera = kittiCamera();
  const ProjectionGeometry geometry = kittiGeometry();
  GridProjectionConfig config;
  config.column_mode = state.range(1) != 0;
  config.column_points = 3;
  std::size_t points = 0;
  for (auto _ : state)
  {
    ProjectedCells cells = projectGrid(grid.view, camera, geometry, config);
    points = cells.size();
    benchmark::DoNotOptimize(cells.u.data());
    benchmark::ClobberMemory();
  }
  state.counters["points"] = static_cast<double>(points);
  state.counters["cells"] = static_cast<double>(grid.view.size());
}
// 100 %: every cell occupied (worst case); 10 %: a busy street scene; 2 %: a typical one.
BENCHMARK(BM_ProjectGrid)
    ->Args({100, 0})
    ->Args({10, 0})
    ->Args({2, 0})
    ->Args({100, 1})
    ->Unit(benchmark::kMillisecond)
    ->Repetitions(10)
    ->ReportAggregatesOnly(true);  // mean, median, stddev and cv over the 10 repetitions

}  // namespace
}  // namespace grid_vision_fusion

int main(int argc, char** argv)
{
  benchmark::AddCustomContext("machine", grid_vision_fusion::machineInfo().describe());
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv))
  {
    return 1;
  }
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
