// Tests of the synthetic world: trajectories, ray-box intersection, vehicle profiles, the ground's
// height field and the simulated lidar.
#include <gtest/gtest.h>

#include <cmath>

#include "grid_vision_fusion/simulation/synthetic_world.h"

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

namespace
{
/// A 4.3 × 1.8 × 1.5 m car profile at the origin, heading +x, on flat ground.
GroundBox carAtOrigin(VehicleShape shape = VehicleShape::kCar)
{
  GroundBox box;
  box.length = 4.3;
  box.width = 1.8;
  box.height = 1.5;
  box.shape = shape;
  box.glass_transmission = 0.5;
  return box;
}

/// z of the first surface straight down at (x, y) from 5 m, or NaN when the ray misses.
double topAt(const GroundBox& box, double x, double y)
{
  const RayHit hit = intersectShape(box, Eigen::Vector3d(x, y, 5.0), -Eigen::Vector3d::UnitZ());
  return hit.hit() ? 5.0 - hit.range : std::nan("");
}
}  // namespace

TEST(VehicleProfile, BonnetLowerThanTheCabinAndRoundedCorners)
{
  const GroundBox car = carAtOrigin();
  // Downward rays along the centre line: the bonnet falls towards the front (0.46 h = 0.69 m at
  // the nose, 0.6 h = 0.9 m at the windscreen's base 1.0 m behind it); the roof is the box's top.
  const double nose = topAt(car, 2.1, 0.0);
  const double bonnet = topAt(car, 1.2, 0.0);
  const double roof = topAt(car, -0.3, 0.0);
  EXPECT_NEAR(nose, 0.70, 0.02);
  EXPECT_GT(bonnet, nose + 0.1);
  EXPECT_LT(bonnet, 0.91);
  EXPECT_NEAR(roof, 1.5, 1e-9);
  // A horizontal ray from ahead at 0.8 m (bonnet height) misses the nose and hits the bonnet's
  // rising surface or the windscreen further back; one at 0.5 m hits the front face.
  const RayHit high = intersectShape(car, Eigen::Vector3d(10.0, 0.0, 0.8), -Eigen::Vector3d::UnitX());
  const RayHit low = intersectShape(car, Eigen::Vector3d(10.0, 0.0, 0.5), -Eigen::Vector3d::UnitX());
  EXPECT_NEAR(low.range, 10.0 - 2.15, 1e-9);
  EXPECT_GT(high.range, low.range + 0.3);
  // The cabin is narrower than the body, its sides lean in: 0.7 m off the centre line the side
  // is at 1.27 m, 0.85 m off it the body's top beside the cabin at the belt line.
  EXPECT_NEAR(topAt(car, -0.3, 0.7), 0.9 + 0.6 * 0.11 / 0.18, 1e-9);
  EXPECT_NEAR(topAt(car, -0.3, 0.85), 0.9, 1e-9);
  // Rounded corners: straight down at the box's corners the car is missed, the box is hit.
  for (const double x : {2.1, -2.1})
  {
    for (const double y : {0.85, -0.85})
    {
      EXPECT_TRUE(std::isnan(topAt(car, x, y))) << x << ", " << y;
      EXPECT_NEAR(topAt(carAtOrigin(VehicleShape::kBox), x, y), 1.5, 1e-9);
    }
  }
  // A ray across the front-left corner at 45°, 0.11 m inside the box's corner: misses the car.
  const Eigen::Vector3d across = Eigen::Vector3d(1.0, -1.0, 0.0).normalized();
  const Eigen::Vector3d corner(2.15 - 0.08, 0.9 - 0.08, 0.4);
  EXPECT_FALSE(intersectShape(car, corner - 5.0 * across, across).hit());
  EXPECT_TRUE(intersectShape(carAtOrigin(VehicleShape::kBox), corner - 5.0 * across, across).hit());
}

TEST(VehicleProfile, WindowsPassAShareOfTheBeams)
{
  GroundBox car = carAtOrigin();
  car.pose = {10.0, 5.0, 0.3};  // anywhere, turned
  car.base_z = 0.2;
  const Eigen::Vector3d side(-std::sin(0.3), std::cos(0.3), 0.0);
  // A ray through the side windows (1.2 m above the bottom) from the right.
  const Eigen::Vector3d origin = Eigen::Vector3d(10.0, 5.0, 1.4) - 6.0 * side;
  const RayHit opaque = intersectShape(car, origin, side, 1e-6, 1.0);
  ASSERT_TRUE(opaque.hit());
  EXPECT_TRUE(opaque.glass);
  EXPECT_NEAR(opaque.range, 6.0 - 0.9 + (0.9 - 0.81) + 0.3 * 0.25, 0.1) << "the near window";
  EXPECT_NEAR(std::abs(opaque.normal.dot(side)), 0.6 / std::hypot(0.6, 0.18), 1e-9) << "leaning in";
  // Draw 0.4 < 0.5: the near window passes it, 0.4 / 0.5 = 0.8 does not pass the far one.
  const RayHit far = intersectShape(car, origin, side, 1e-6, 0.4);
  ASSERT_TRUE(far.hit());
  EXPECT_TRUE(far.glass);
  EXPECT_NEAR(far.range - opaque.range, 2.0 * (6.0 - opaque.range) - 0.0, 0.2) << "the far window";
  // Draw 0.1: both pass (a quarter of the beams).
  EXPECT_FALSE(intersectShape(car, origin, side, 1e-6, 0.1).hit());
  int through = 0, near_window = 0;
  for (int i = 0; i < 1000; ++i)
  {
    const RayHit hit = intersectShape(car, origin, side, 1e-6, (i + 0.5) / 1000.0);
    through += hit.hit() ? 0 : 1;
    near_window += hit.hit() && std::abs(hit.range - opaque.range) < 1e-9 ? 1 : 0;
  }
  EXPECT_EQ(through, 250);
  EXPECT_EQ(near_window, 500);
  // The roof is not glass; neither is the body below the belt line.
  const RayHit roof =
      intersectShape(car, Eigen::Vector3d(10.0, 5.0, 5.0), -Eigen::Vector3d::UnitZ(), 1e-6, 0.0);
  EXPECT_FALSE(roof.glass);
  EXPECT_NEAR(roof.range, 5.0 - 1.7, 1e-9);
  const RayHit door = intersectShape(car, origin - Eigen::Vector3d(0, 0, 0.8), side, 1e-6, 0.0);
  EXPECT_FALSE(door.glass);
  EXPECT_NEAR(door.range, 6.0 - 0.9, 1e-9);
}

TEST(VehicleProfile, AVanHasGlassInItsCabOnly)
{
  GroundBox van = carAtOrigin(VehicleShape::kVan);
  van.length = 5.0;
  van.width = 2.0;
  van.height = 2.2;
  // From the left at 1.7 m: the cab's side window ahead, the cargo body's panel behind.
  const RayHit cab =
      intersectShape(van, Eigen::Vector3d(1.2, 6.0, 1.7), -Eigen::Vector3d::UnitY(), 1e-6, 0.9);
  const RayHit cargo =
      intersectShape(van, Eigen::Vector3d(-1.0, 6.0, 1.7), -Eigen::Vector3d::UnitY(), 1e-6, 0.0);
  EXPECT_TRUE(cab.glass);
  EXPECT_FALSE(cargo.glass);
  EXPECT_NEAR(cargo.range, 6.0 - (0.96 - 0.08 * 0.71 / 1.21), 1e-9);
  EXPECT_NEAR(topAt(van, 0.0, 0.0), 2.2, 1e-9);
  EXPECT_LT(topAt(van, 2.4, 0.0), 0.9) << "a short bonnet";
}

TEST(VehicleProfile, EveryHitLiesInTheLabelledBox)
{
  for (const VehicleShape shape : {VehicleShape::kCar, VehicleShape::kVan})
  {
    GroundBox box = carAtOrigin(shape);
    box.pose = {3.0, -2.0, 1.0};
    std::mt19937 rng(3);
    std::uniform_real_distribution<double> uniform(-1.0, 1.0);
    int hits = 0;
    for (int i = 0; i < 2000; ++i)
    {
      const Eigen::Vector3d origin(3.0 + 8.0 * uniform(rng), -2.0 + 8.0 * uniform(rng),
                                   2.5 + 0.9 * uniform(rng));
      const Eigen::Vector3d target(3.0 + 2.5 * uniform(rng), -2.0 + 1.5 * uniform(rng),
                                   0.75 + 0.8 * uniform(rng));
      const Eigen::Vector3d direction = (target - origin).normalized();
      const RayHit hit = intersectShape(box, origin, direction, 1e-6, 0.5 * (uniform(rng) + 1.0));
      if (!hit.hit())
      {
        continue;
      }
      ++hits;
      const RayHit outer = intersectBox(box, origin, direction);
      ASSERT_TRUE(outer.hit());
      ASSERT_GE(hit.range, outer.range - 1e-9);
      const Eigen::Vector3d p = origin + hit.range * direction;
      const Eigen::Vector2d local = Eigen::Rotation2Dd(-1.0) * Eigen::Vector2d(p.x() - 3.0, p.y() + 2.0);
      ASSERT_LE(std::abs(local.x()), 4.3 / 2 + 1e-9);
      ASSERT_LE(std::abs(local.y()), 1.8 / 2 + 1e-9);
      ASSERT_GE(p.z(), -1e-9);
      ASSERT_LE(p.z(), 1.5 + 1e-9);
    }
    EXPECT_GT(hits, 500) << vehicleShapeName(shape);
  }
}

TEST(GroundSurface, CamberKerbsAndVerges)
{
  GroundSurface g;
  g.slope_x = 0.01;
  g.center_y = 1.0;
  g.half_width = 6.0;
  g.camber = 0.03;
  g.kerb_height = 0.15;
  g.verge_rise_left = 0.4;
  g.verge_rise_right = 0.1;
  g.verge_width = 2.0;
  ASSERT_TRUE(g.profiled());
  EXPECT_DOUBLE_EQ(g.z(10.0, 1.0), 0.1) << "the crown: the plane";
  EXPECT_NEAR(g.z(10.0, 1.0 - 2.0), 0.1 - 0.06, 1e-12);
  EXPECT_NEAR(g.z(0.0, 7.0), -0.18, 1e-12) << "the left road edge";
  EXPECT_NEAR(g.z(0.0, 7.0 + 1e-9), -0.03, 1e-6) << "on the kerb";
  EXPECT_NEAR(g.z(0.0, 8.0), -0.03 + 0.2, 1e-12) << "half way up the left verge";
  EXPECT_NEAR(g.z(0.0, 20.0), -0.03 + 0.4, 1e-12);
  EXPECT_NEAR(g.z(0.0, -20.0), -0.03 + 0.1, 1e-12);
  // Downward rays meet the surface at z(x, y), anywhere.
  for (double y = -12.0; y <= 12.0; y += 0.37)
  {
    const RayHit hit = g.cast(Eigen::Vector3d(5.0, y, 3.0), -Eigen::Vector3d::UnitZ(), 0.1, 100.0);
    ASSERT_EQ(hit.object, RayHit::kGround);
    ASSERT_NEAR(3.0 - hit.range, g.z(5.0, y), 1e-9) << y;
  }
  // Slanted rays (a lidar's) meet it where z(x, y) is the ray's height.
  const Eigen::Vector3d origin(0.0, -0.75, 1.73);
  for (double azimuth = 0.0; azimuth < 2.0 * M_PI; azimuth += 0.1)
  {
    const Eigen::Vector3d d(std::cos(azimuth) * std::cos(0.15), std::sin(azimuth) * std::cos(0.15),
                            -std::sin(0.15));
    const RayHit hit = g.cast(origin, d, 0.1, 100.0);
    ASSERT_TRUE(hit.hit());
    const Eigen::Vector3d p = origin + hit.range * d;
    if (std::abs(hit.normal.z()) > 0.5)
    {
      ASSERT_NEAR(p.z(), g.z(p.x(), p.y()), 1e-9) << azimuth;
    }
  }
  // A low ray across the road meets the left kerb's face, facing the road.
  const RayHit kerb = g.cast(Eigen::Vector3d(0.0, 5.0, -0.1), Eigen::Vector3d::UnitY(), 0.1, 100.0);
  ASSERT_EQ(kerb.object, RayHit::kGround);
  EXPECT_NEAR(kerb.range, 2.0, 1e-9);
  EXPECT_TRUE(kerb.normal.isApprox(-Eigen::Vector3d::UnitY()));
  EXPECT_THROW(
      []
      {
        GroundSurface bad;
        bad.camber = -0.01;
        bad.validate();
      }(),
      std::invalid_argument);
}

TEST(GroundSurface, ActorsAndBuildingsStandOnIt)
{
  GroundSurface g;
  g.camber = 0.03;
  g.kerb_height = 0.15;
  g.verge_rise_left = 0.5;
  g.verge_width = 3.0;
  Actor car;
  car.trajectory = Trajectory::parked({10.0, -5.0, 0.0});
  SceneryBox building;
  building.box.pose = {0.0, 10.0, 0.0};
  building.box.length = 20.0;
  building.box.width = 6.0;  // from y = 7 (on the verge's slope) to 13 (beyond it)
  building.box.height = 8.0;
  const SceneSnapshot scene({car}, {building}, 0.0, g);
  EXPECT_NEAR(scene.actorBoxes()[0].base_z, -0.15, 1e-12);
  EXPECT_NEAR(scene.sceneryBoxes()[0].base_z, g.z(0.0, 7.0), 1e-12) << "its lowest corner";
  // The lidar sees the car's rear face from behind, above the cambered road.
  const RayHit hit = scene.cast(Eigen::Vector3d(0.0, -5.0, 0.0), Eigen::Vector3d::UnitX(), 0.1, 100.0);
  EXPECT_EQ(hit.object, 0);
  EXPECT_NEAR(hit.range, 10.0 - 2.0, 1e-9);
  // And the flat default leaves everything where it stood.
  const SceneSnapshot flat({car}, {building}, 0.0);
  EXPECT_EQ(flat.actorBoxes()[0].base_z, 0.0);
  EXPECT_EQ(flat.sceneryBoxes()[0].base_z, 0.0);
  EXPECT_FALSE(flat.ground().profiled());
  EXPECT_FALSE(flat.hasGlass());
}

TEST(Lidar, SeesThroughTheWindowsOfCarProfiles)
{
  // A car 8 m to the left, a wall 4 m behind it: beams through the side windows reach the car's
  // far side or the wall; a box hides the wall at that height.
  Actor car;
  car.length = 4.3;
  car.width = 1.8;
  car.height = 1.5;
  car.trajectory = Trajectory::parked({0.0, 8.0, 0.0});
  SceneryBox wall;
  wall.box.pose = {0.0, 13.0, 0.0};
  wall.box.length = 30.0;
  wall.box.width = 1.0;
  wall.box.height = 6.0;
  LidarConfig config;
  config.azimuth_steps = 2048;
  config.dropout = 0.0;
  config.range_noise_std = 0.0;
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.translation().z() = 1.73;
  const auto wallBehindCar = [&](VehicleShape shape)
  {
    car.shape = shape;
    const SceneSnapshot scene({car}, {wall}, 0.0);
    std::mt19937 rng(5);
    int count = 0;
    for (const LidarPoint& p : simulateLidarScan(scene, pose, config, rng))
    {
      // Wall hits 0.6 to 1.3 m above the ground: below the box's shadow line.
      count += std::abs(p.x) < 1.0 && p.y > 12.4 && p.y < 12.6 && p.z > -1.13 && p.z < -0.43 ? 1 : 0;
    }
    return count;
  };
  EXPECT_GT(wallBehindCar(VehicleShape::kCar), 5);
  EXPECT_EQ(wallBehindCar(VehicleShape::kBox), 0);
}

}  // namespace grid_vision_fusion
