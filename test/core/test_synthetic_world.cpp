// Tests of the synthetic world: trajectories, ray-box intersection and the simulated lidar.
#include <gtest/gtest.h>

#include <cmath>

#include "grid_vision_fusion/core/synthetic_world.h"

namespace grid_vision_fusion
{
TEST(Trajectory, WaypointsInterpolateAndHoldTheHeading)
{
  // Stands at (0, 0) until t = 1, drives north 10 m in 2 s, stands again.
  const Trajectory t = Trajectory::waypoints({{1.0, 0.0, 0.0}, {3.0, 0.0, 10.0}});
  EXPECT_DOUBLE_EQ(t.poseAt(0.0).y, 0.0);
  EXPECT_NEAR(t.poseAt(0.0).yaw, M_PI / 2, 1e-12) << "standing before the start faces where it will go";
  EXPECT_DOUBLE_EQ(t.poseAt(2.0).y, 5.0);
  EXPECT_DOUBLE_EQ(t.velocityAt(2.0).y(), 5.0);
  EXPECT_DOUBLE_EQ(t.velocityAt(0.5).norm(), 0.0);
  EXPECT_DOUBLE_EQ(t.poseAt(9.0).y, 10.0);
  EXPECT_NEAR(t.poseAt(9.0).yaw, M_PI / 2, 1e-12);
  EXPECT_DOUBLE_EQ(t.velocityAt(9.0).norm(), 0.0);
  EXPECT_THROW(Trajectory::waypoints({{1.0, 0.0, 0.0}, {1.0, 1.0, 0.0}}), std::invalid_argument);
  EXPECT_THROW(Trajectory::waypoints({}), std::invalid_argument);
}

TEST(Trajectory, StopAndGoKeepsTheHeadingWhileStanding)
{
  // East 10 m, stand 2 s, then north.
  const Trajectory t =
      Trajectory::waypoints({{0.0, 0.0, 0.0}, {1.0, 10.0, 0.0}, {3.0, 10.0, 0.0}, {4.0, 10.0, 5.0}});
  EXPECT_NEAR(t.poseAt(2.0).yaw, 0.0, 1e-12);
  EXPECT_DOUBLE_EQ(t.velocityAt(2.0).norm(), 0.0);
  EXPECT_NEAR(t.poseAt(3.5).yaw, M_PI / 2, 1e-12);
}

TEST(Trajectory, ConstantTurnClosesTheCircle)
{
  const Pose2D start{5.0, -2.0, 0.3};
  const double speed = 4.0;
  const double yaw_rate = 0.5;
  const Trajectory t = Trajectory::constantTurn(start, speed, yaw_rate);
  const double period = 2.0 * M_PI / yaw_rate;
  EXPECT_NEAR(t.poseAt(period).x, start.x, 1e-9);
  EXPECT_NEAR(t.poseAt(period).y, start.y, 1e-9);
  // Half a turn: displaced by the diameter 2·v/ω = 16 m perpendicular to the start heading.
  const Pose2D half = t.poseAt(period / 2.0);
  EXPECT_NEAR(std::hypot(half.x - start.x, half.y - start.y), 16.0, 1e-9);
  EXPECT_NEAR(t.velocityAt(1.0).norm(), speed, 1e-12);
  const Trajectory straight = Trajectory::constantTurn({0.0, 0.0, M_PI}, 10.0, 0.0);
  EXPECT_NEAR(straight.poseAt(0.5).x, -5.0, 1e-12);
}

TEST(RayBox, EntryRangeAndNormal)
{
  GroundBox box;
  box.pose = {10.0, 0.0, 0.0};
  box.length = 4.0;
  box.width = 2.0;
  box.height = 1.5;
  const RayHit hit = intersectBox(box, Eigen::Vector3d(0.0, 0.0, 1.0), Eigen::Vector3d::UnitX());
  EXPECT_NEAR(hit.range, 8.0, 1e-12);
  EXPECT_TRUE(hit.normal.isApprox(-Eigen::Vector3d::UnitX()));
  // Over the roof: miss.
  EXPECT_FALSE(
      std::isfinite(intersectBox(box, Eigen::Vector3d(0.0, 0.0, 1.6), Eigen::Vector3d::UnitX()).range));
  // Turned 90°: now 2 m wide along x, so the face is at 9 m.
  box.pose.yaw = M_PI / 2;
  EXPECT_NEAR(intersectBox(box, Eigen::Vector3d(0.0, 0.0, 1.0), Eigen::Vector3d::UnitX()).range, 9.0, 1e-9);
  // From above: the roof, normal up.
  const RayHit roof = intersectBox(box, Eigen::Vector3d(10.0, 0.0, 5.0), -Eigen::Vector3d::UnitZ());
  EXPECT_NEAR(roof.range, 3.5, 1e-12);
  EXPECT_TRUE(roof.normal.isApprox(Eigen::Vector3d::UnitZ()));
}

TEST(SceneSnapshot, NearestHitAndHiddenActors)
{
  Actor near_car;
  near_car.trajectory = Trajectory::parked({10.0, 0.0, 0.0});
  Actor far_car;
  far_car.trajectory = Trajectory::parked({20.0, 0.0, 0.0});
  SceneryBox wall;
  wall.box.pose = {40.0, 0.0, 0.0};
  wall.box.length = 1.0;
  wall.box.width = 30.0;
  wall.box.height = 5.0;
  const SceneSnapshot scene({near_car, far_car}, {wall}, 0.0);
  const Eigen::Vector3d origin(0.0, 0.0, 1.0);
  const RayHit hit = scene.cast(origin, Eigen::Vector3d::UnitX(), 0.1, 100.0);
  EXPECT_EQ(hit.object, 0);
  EXPECT_NEAR(hit.range, 8.0, 1e-12);
  std::vector<int> along;
  scene.actorsAlong(origin, Eigen::Vector3d::UnitX(), 0.1, 100.0, along);
  EXPECT_EQ(along, (std::vector<int>{0, 1}));
  // Above the cars: the wall.
  EXPECT_EQ(scene.cast(Eigen::Vector3d(0.0, 0.0, 3.0), Eigen::Vector3d::UnitX(), 0.1, 100.0).object,
            RayHit::kSceneryBase);
  // Downward: the ground at 1 m / sin(30°) = 2 m.
  const RayHit ground = scene.cast(origin, Eigen::Vector3d(std::cos(M_PI / 6), 0.0, -0.5), 0.1, 100.0);
  EXPECT_EQ(ground.object, RayHit::kGround);
  EXPECT_NEAR(ground.range, 2.0, 1e-12);
  // Range limit.
  EXPECT_FALSE(scene.cast(origin, Eigen::Vector3d::UnitX(), 0.1, 7.0).hit());
  // Culling: boxes entirely beyond 15 m of the origin are left out (the far car at 20 m and the
  // wall at 40 m); the near car at 10 m stays.
  SceneSnapshot culled = scene;
  culled.cullBeyond(Eigen::Vector2d::Zero(), 15.0);
  EXPECT_EQ(culled.cast(Eigen::Vector3d(0.0, 0.0, 3.0), Eigen::Vector3d::UnitX(), 0.1, 100.0).object,
            RayHit::kNothing);
  along.clear();
  culled.actorsAlong(origin, Eigen::Vector3d::UnitX(), 0.1, 100.0, along);
  EXPECT_EQ(along, (std::vector<int>{0}));
}

TEST(Lidar, Hdl64LayoutAndGroundReturns)
{
  const std::vector<double> e = LidarConfig::hdl64Elevations();
  ASSERT_EQ(e.size(), 64U);
  EXPECT_NEAR(e.front() * 180.0 / M_PI, 2.0, 1e-9);
  EXPECT_NEAR(e[31] * 180.0 / M_PI, 2.0 - 31.0 / 3.0, 1e-9);
  EXPECT_NEAR(e.back() * 180.0 / M_PI, -24.33, 1e-9);

  // Flat empty world, sensor 1.73 m above the ground, no noise, no dropout: the beams at or
  // below −0.826° (1.73 m / tan = 120 m) reach the ground: 23 upper + 32 lower = 55 beams.
  LidarConfig config;
  config.azimuth_steps = 360;
  config.range_noise_std = 0.0;
  config.dropout = 0.0;
  const SceneSnapshot scene({}, {}, 0.0);
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.translation().z() = 1.73;
  std::mt19937 rng(1);
  const std::vector<LidarPoint> points = simulateLidarScan(scene, pose, config, rng);
  EXPECT_EQ(points.size(), 55U * 360U);
  for (const auto& p : points)
  {
    ASSERT_NEAR(p.z, -1.73, 1e-4);
    ASSERT_GE(std::hypot(p.x, p.y), 3.8);  // lowest beam −24.33°: 1.73 / tan = 3.83 m
  }
}

TEST(Lidar, BoxAheadNoiseDropoutAndDeterminism)
{
  Actor car;
  car.trajectory = Trajectory::parked({10.0, 0.0, 0.0});
  const SceneSnapshot scene({car}, {}, 0.0);
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.translation().z() = 1.73;
  LidarConfig config;
  config.azimuth_steps = 720;
  std::mt19937 rng(7);
  const std::vector<LidarPoint> a = simulateLidarScan(scene, pose, config, rng);
  std::mt19937 same(7);
  const std::vector<LidarPoint> b = simulateLidarScan(scene, pose, config, same);
  ASSERT_EQ(a.size(), b.size());
  EXPECT_EQ(a[100].x, b[100].x);
  // Returns from the rear face (x = 8 m, |y| < 0.9, z in [−1.73, −0.23]) exist, with 2 cm noise.
  int on_face = 0;
  for (const auto& p : a)
  {
    if (std::abs(p.y) < 0.85 && p.z > -1.6 && p.z < -0.3 && p.x > 7.0 && p.x < 9.0)
    {
      ++on_face;
      EXPECT_NEAR(p.x, 8.0, 0.15);
    }
  }
  EXPECT_GT(on_face, 20);
  // Dropout 2 %: about 98 % of the noiseless count.
  LidarConfig clean = config;
  clean.dropout = 0.0;
  std::mt19937 rng2(7);
  const double kept = static_cast<double>(a.size()) / simulateLidarScan(scene, pose, clean, rng2).size();
  EXPECT_NEAR(kept, 0.98, 0.01);
  config.dropout = 1.0;
  EXPECT_THROW(simulateLidarScan(scene, pose, config, rng), std::invalid_argument);
}

}  // namespace grid_vision_fusion
