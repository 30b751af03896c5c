// Benchmark of what issue 12 adds to the fusion per image: the object centres (estimateCentres())
// and the tracker (trackObjects()), against the per-frame fusion alone (fuse()). Input: a
// synthetic street seen by a KITTI-sized camera, N cars (parked and moving at 2-12 m/s), each
// with the cells of its visible faces (0.2 m grid) in its fusion band plus clutter cells, and
// 20 000 other projected cells; one iteration = the next image (10 Hz) of the sequence.
// Not a test: run `rosrun grid_vision_fusion bench_fusion_tracking`.
#include <benchmark/benchmark.h>

#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "grid_vision_fusion/cli/machine_info.h"
#include "grid_vision_fusion/fusion/fusion.h"
#include "grid_vision_fusion/fusion/object_tracking.h"
#include "grid_vision_fusion/fusion/tracker.h"

namespace grid_vision_fusion
{
namespace
{
constexpr double kFramePeriodS = 0.1;
constexpr double kFocalPx = 721.5;
constexpr double kCentreU = 609.6;
constexpr double kCentreV = 172.9;
constexpr double kCameraHeightM = 1.65;

struct Car
{
  double x, y, vx;
};

/// The cars of the scene: rows of parked cars on both sides and moving cars in two lanes,
/// between 6 and 40 m ahead.
std::vector<Car> scene(int count)
{
  std::vector<Car> cars;
  for (int i = 0; i < count; ++i)
  {
    const int lane = i % 4;
    const double y = lane == 0 ? -5.5 : lane == 1 ? 5.5 : lane == 2 ? -1.8 : 1.8;
    const double vx = lane < 2 ? 0.0 : 2.0 + 10.0 * (i % 5) / 4.0;
    cars.push_back(Car{6.0 + 34.0 * (i / 4) / std::max(1, (count - 1) / 4), y, vx});
  }
  return cars;
}

/// The image of the scene at time t: one box per car, its visible rear and side cells, clutter.
void render(const std::vector<Car>& cars, double t, std::mt19937& random, std::vector<Detection>& detections,
            ProjectedPoints& points)
{
  detections.clear();
  points = ProjectedPoints();
  std::normal_distribution<double> jitter(0.0, 0.05);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  auto project = [](double x, double y, double z, float& u, float& v)
  {
    u = static_cast<float>(kCentreU - kFocalPx * y / x);
    v = static_cast<float>(kCentreV + kFocalPx * (kCameraHeightM - z) / x);
  };
  for (const Car& car : cars)
  {
    // Moving cars drive through a 40 m stretch and come back in at its start.
    const double rear = 6.0 + std::fmod(car.x - 6.0 + car.vx * t, 40.0) - 1.95;
    Detection d;
    d.label = "car";
    d.score = 0.9F;
    float u0, v0, u1, v1;
    project(rear, car.y + 0.8, 1.5, u0, v0);
    project(rear, car.y - 0.8, 0.0, u1, v1);
    d.box = BoundingBox{std::max(0.F, u0), std::max(0.F, v0), std::min(1241.F, u1), std::min(374.F, v1)};
    detections.push_back(d);
    const CellState state = car.vx > 0.0 ? CellState::kDynamic : CellState::kStatic;
    for (double dy = -0.8; dy <= 0.8; dy += 0.2)  // rear face
    {
      float u, v;
      project(rear, car.y + dy, 0.0, u, v);
      points.add(u, v, static_cast<float>(rear + jitter(random)), static_cast<float>(car.y + dy),
                 static_cast<float>(car.vx), 0.F, state);
    }
    const double side = car.y > 0 ? car.y - 0.8 : car.y + 0.8;
    for (double dx = 0.2; dx <= 3.9; dx += 0.2)  // the side facing the road
    {
      float u, v;
      project(rear + dx, side, 0.0, u, v);
      points.add(u, v, static_cast<float>(rear + dx), static_cast<float>(side + jitter(random)),
                 static_cast<float>(car.vx), 0.F, state);
    }
  }
  for (int i = 0; i < 20000; ++i)  // buildings and kerbs elsewhere in the image
  {
    const double x = 5.0 + 45.0 * uniform(random);
    const double y = (uniform(random) < 0.5 ? -1.0 : 1.0) * (8.0 + 4.0 * uniform(random));
    float u, v;
    project(x, y, 0.0, u, v);
    points.add(u, v, static_cast<float>(x), static_cast<float>(y), 0.F, 0.F, CellState::kStatic);
  }
}

/// Argument 0: cars in the image; argument 1: 0 = the per-frame fusion (fuse()), 1 = fuse() +
/// estimateCentres() + trackObjects(), 2 = only what issue 12 adds: estimateCentres() +
/// trackObjects() on a copy of the image's fuse() result made beforehand (the copy timed too),
/// 3 = as 2 without the grid's cell size, so without the registration of the objects' hits.
void BM_FusionPerImage(benchmark::State& state)
{
  const std::vector<Car> cars = scene(static_cast<int>(state.range(0)));
  const int mode = static_cast<int>(state.range(1));
  FusionConfig config;
  Tracker tracker;
  std::mt19937 random(7);
  // A 10 s sequence rendered beforehand, replayed in a loop (the tracker resets on the jump
  // back, once per 100 images).
  constexpr int kImages = 100;
  std::vector<std::vector<Detection>> detections(kImages);
  std::vector<ProjectedPoints> points(kImages);
  std::vector<FusionResult> fused(kImages);
  for (int k = 0; k < kImages; ++k)
  {
    render(cars, k * kFramePeriodS, random, detections[k], points[k]);
    points[k].resolution = mode == 3 ? 0.0 : 0.2;
    fused[k] = fuse(detections[k], points[k].view(), config);
  }
  int k = 0;
  std::size_t published = 0;
  for (auto _ : state)
  {
    const ProjectedPointsView view = points[k].view();
    FusionResult result = mode >= 2 ? fused[k] : fuse(detections[k], view, config);
    if (mode != 0)
    {
      estimateCentres(result, detections[k], view, 0.0, 0.0, config.centre);
      trackObjects(tracker, k * kFramePeriodS, detections[k], 1242, view, result);
    }
    published += result.objects.size();
    benchmark::DoNotOptimize(result.objects.data());
    k = (k + 1) % kImages;
  }
  state.counters["objects_per_image"] =
      benchmark::Counter(static_cast<double>(published), benchmark::Counter::kAvgIterations);
}
BENCHMARK(BM_FusionPerImage)
    ->ArgsProduct({{10, 30, 60}, {0, 1, 2, 3}})
    ->Unit(benchmark::kMillisecond)
    ->Repetitions(5)
    ->ReportAggregatesOnly(true);

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
