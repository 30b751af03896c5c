// Tests of the scenario loader on the default scenario and on broken files.
#include <gtest/gtest.h>

#include <fstream>

#include "grid_vision_fusion/simulation/synthetic_scenario.h"

namespace grid_vision_fusion
{
namespace
{
std::string writeTemp(const std::string& name, const std::string& content)
{
  const std::string path = testing::TempDir() + name;
  std::ofstream(path) << content;
  return path;
}

std::string errorOf(const std::string& yaml)
{
  try
  {
    loadScenario(writeTemp("scenario.yaml", yaml));
  }
  catch (const std::runtime_error& e)
  {
    return e.what();
  }
  return "";
}
}  // namespace

TEST(SyntheticScenario, DefaultScenario)
{
  const SyntheticScenario s = loadScenario(std::string(GVF_SOURCE_DIR) + "/config/synthetic_drive.yaml");
  EXPECT_EQ(s.seed, 42U);
  EXPECT_EQ(s.frameCount(), 100);
  EXPECT_DOUBLE_EQ(s.frameTime(25), 2.5);
  EXPECT_EQ(s.actors.size(), 13U);
  EXPECT_EQ(s.scenery.size(), 6U);
  EXPECT_EQ(s.lidar.azimuth_steps, 2048);
  // Ego: 9 m/s average over the first 5 s.
  EXPECT_DOUBLE_EQ(s.ego.poseAt(2.5).x, 22.5);
  EXPECT_DOUBLE_EQ(s.ego.velocityAt(7.0).x(), 12.0);
  // The parked car that starts: standing at (65, −5.2) until t = 4, then moving.
  const Actor& starter = s.actors[11];
  EXPECT_DOUBLE_EQ(starter.trajectory.velocityAt(3.0).norm(), 0.0);
  EXPECT_GT(starter.trajectory.velocityAt(4.5).norm(), 5.0);
  EXPECT_EQ(s.actors[12].type, "Cyclist");
  EXPECT_EQ(s.actors[0].color_rgb, 0xB03A2EU);
}

TEST(SyntheticScenario, ErrorsNameTheEntry)
{
  EXPECT_NE(errorOf("duration: 1\n").find("missing key 'ego'"), std::string::npos);
  EXPECT_NE(errorOf("ego: {parked: {x: 0, y: 0}}\nactors:\n  - {type: Car, parked: {x: 1, y: 2}}\n")
                .find("actors[0]: missing key 'size'"),
            std::string::npos);
  EXPECT_NE(errorOf("ego: {parked: {x: 0, y: 0}, waypoints: [[0, 0, 0]]}\n").find("exactly one of"),
            std::string::npos);
  EXPECT_NE(errorOf("ego: {waypoints: [[1, 0, 0], [0, 5, 0]]}\n").find("ego.waypoints: waypoint times"),
            std::string::npos);
  EXPECT_NE(errorOf("ego: {parked: {x: 0, y: 0}}\nactors:\n  - {type: Car, size: [4, 2, 1.5], color: red, "
                    "parked: {x: 1, y: 2}}\n")
                .find("colour \"red\""),
            std::string::npos);
  EXPECT_NE(errorOf("ego: {parked: {x: 0, y: 0}}\nduration: -1\n").find("duration must be > 0"),
            std::string::npos);
  EXPECT_NE(errorOf("ego: {parked: {x: zero, y: 0}}\n").find("'x' has the wrong type"), std::string::npos);
  EXPECT_NE(errorOf("ego: [unclosed\n").find("cannot read scenario"), std::string::npos);
  EXPECT_EQ(parseColor("#0a0B0c"), 0x0A0B0CU);
  EXPECT_NE(errorOf("ego: {waypoints: [[0, 0, 0, 0], [1, 5, 0]]}\n")
                .find("ego.waypoints[1]: every waypoint is [t, x, y], or every one [t, x, y, yaw]"),
            std::string::npos);
  EXPECT_NE(errorOf("ego: {waypoints: [[0, 0]]}\n").find("ego.waypoints[0]: every waypoint"),
            std::string::npos);
}

TEST(SyntheticScenario, WaypointsWithYawKeepTheGivenHeading)
{
  // A car reversing out of a parking space: it moves along +y with its nose towards −y, then
  // turns to +x while still reversing, stands, and drives off forwards.
  const SyntheticScenario s =
      loadScenario(writeTemp("reversing.yaml",
                             "ego: {parked: {x: 0, y: 0}}\n"
                             "actors:\n"
                             "  - {type: Car, size: [4.3, 1.8, 1.5], waypoints: [[1, 20, -6, "
                             "-1.5708], [3, 20, -4, -1.5708], [5, 22, -2, 0], [6, 22, -2, 0], "
                             "[8, 32, -2, 0]]}\n"));
  const Trajectory& car = s.actors.at(0).trajectory;
  EXPECT_NEAR(car.poseAt(0.0).yaw, -1.5708, 1e-9);  // standing before the first waypoint
  const Pose2D reversing = car.poseAt(2.0);
  EXPECT_DOUBLE_EQ(reversing.y, -5.0);
  EXPECT_NEAR(reversing.yaw, -1.5708, 1e-9);  // moving along +y, heading −y
  EXPECT_NEAR(car.velocityAt(2.0).y(), 1.0, 1e-9);
  EXPECT_NEAR(car.poseAt(4.0).yaw, -0.7854, 1e-9);  // heading interpolated between waypoints
  EXPECT_NEAR(car.poseAt(5.5).yaw, 0.0, 1e-9);
  EXPECT_NEAR(car.velocityAt(7.0).x(), 5.0, 1e-9);
  EXPECT_NEAR(car.poseAt(9.0).x, 32.0, 1e-9);
}

TEST(SyntheticScenario, RealismKeysAreOffByDefault)
{
  const SyntheticScenario s = loadScenario(std::string(GVF_SOURCE_DIR) + "/config/synthetic_drive.yaml");
  EXPECT_FALSE(s.ground.profiled());
  EXPECT_EQ(s.ground.slope_x, 0.0);
  EXPECT_FALSE(s.vehicle_profiles);
  EXPECT_FALSE(s.ins_error.enabled());
  for (const Actor& actor : s.actors)
  {
    EXPECT_EQ(actor.shape, VehicleShape::kBox);
  }
}

TEST(SyntheticScenario, GroundVehicleShapeAndInsErrorKeys)
{
  const SyntheticScenario s = loadScenario(writeTemp(
      "realism.yaml",
      "road: {center_y: 0.5, half_width: 6.5}\n"
      "ground: {slope: 0.004, camber: 0.03, kerb_height: 0.15, verge_rise_left: 0.1, verge_rise_right: 0.45,"
      " verge_width: 2.5}\n"
      "vehicle_shape: car\n"
      "glass_transmission: 0.3\n"
      "ins_error: {position_std: 0.02, position_correlation: 0.5, height_std: 0.01, yaw_drift_rate: 0.0028,"
      " yaw_walk_std: 0.001, roll_std: 0.002, pitch_std: 0.003}\n"
      "ego: {parked: {x: 0, y: 0}}\n"
      "actors:\n"
      "  - {type: Car, size: [4.3, 1.8, 1.5], parked: {x: 1, y: 2}}\n"
      "  - {type: Van, size: [5, 2, 2.2], parked: {x: 1, y: 9}}\n"
      "  - {type: Truck, size: [8, 2.5, 3.2], parked: {x: 1, y: 19}}\n"
      "  - {type: Car, size: [4.3, 1.8, 1.5], shape: box, parked: {x: 1, y: 29}}\n"
      "  - {type: Truck, size: [6, 2.2, 2.6], shape: van, parked: {x: 1, y: 39}}\n"));
  EXPECT_DOUBLE_EQ(s.ground.slope_x, 0.004);
  EXPECT_DOUBLE_EQ(s.ground.camber, 0.03);
  EXPECT_DOUBLE_EQ(s.ground.kerb_height, 0.15);
  EXPECT_DOUBLE_EQ(s.ground.verge_rise_left, 0.1);
  EXPECT_DOUBLE_EQ(s.ground.verge_rise_right, 0.45);
  EXPECT_DOUBLE_EQ(s.ground.verge_width, 2.5);
  EXPECT_DOUBLE_EQ(s.ground.center_y, 0.5) << "the road's";
  EXPECT_DOUBLE_EQ(s.ground.half_width, 6.5);
  EXPECT_TRUE(s.vehicle_profiles);
  ASSERT_EQ(s.actors.size(), 5U);
  EXPECT_EQ(s.actors[0].shape, VehicleShape::kCar);
  EXPECT_EQ(s.actors[1].shape, VehicleShape::kVan);
  EXPECT_EQ(s.actors[2].shape, VehicleShape::kBox) << "trucks keep their box";
  EXPECT_EQ(s.actors[3].shape, VehicleShape::kBox) << "given";
  EXPECT_EQ(s.actors[4].shape, VehicleShape::kVan) << "given";
  EXPECT_DOUBLE_EQ(s.actors[0].glass_transmission, 0.3);
  EXPECT_DOUBLE_EQ(s.actors[0].boxAt(0.0).glass_transmission, 0.3);
  EXPECT_EQ(s.actors[1].boxAt(0.0).shape, VehicleShape::kVan);
  EXPECT_DOUBLE_EQ(s.ins_error.position_std, 0.02);
  EXPECT_DOUBLE_EQ(s.ins_error.position_correlation_s, 0.5);
  EXPECT_DOUBLE_EQ(s.ins_error.height_std, 0.01);
  EXPECT_DOUBLE_EQ(s.ins_error.yaw_drift_rate, 0.0028);
  EXPECT_DOUBLE_EQ(s.ins_error.yaw_walk_std, 0.001);
  EXPECT_DOUBLE_EQ(s.ins_error.roll_std, 0.002);
  EXPECT_DOUBLE_EQ(s.ins_error.pitch_std, 0.003);
  EXPECT_TRUE(s.ins_error.enabled());
}

TEST(SyntheticScenario, RealismKeyErrorsNameTheEntry)
{
  const std::string ego = "ego: {parked: {x: 0, y: 0}}\n";
  EXPECT_NE(errorOf(ego + "ground: {camber_percent: 2}\n")
                .find("ground: unknown key 'camber_percent' (known: slope,"),
            std::string::npos);
  EXPECT_NE(errorOf(ego + "ground: {camber: -0.02}\n")
                .find("ground: camber, kerb_height and the verge rises must be >= 0"),
            std::string::npos);
  EXPECT_NE(errorOf(ego + "ground: {verge_width: 0}\n").find("ground: verge_width must be > 0"),
            std::string::npos);
  EXPECT_NE(
      errorOf(ego + "ground: {kerb_height: high}\n").find("ground: key 'kerb_height' has the wrong type"),
      std::string::npos);
  EXPECT_NE(errorOf(ego + "ground: 0.1\n").find("ground: expected a mapping"), std::string::npos);
  EXPECT_NE(errorOf(ego + "vehicle_shape: van\n").find("vehicle_shape \"van\" is not one of box, car"),
            std::string::npos);
  EXPECT_NE(errorOf(ego + "actors:\n  - {type: Car, size: [4, 2, 1.5], shape: bus, parked: {x: 1, y: 2}}\n")
                .find("actors[0]: shape \"bus\" is not one of box, car, van"),
            std::string::npos);
  EXPECT_NE(errorOf(ego + "glass_transmission: 1.5\n").find("glass_transmission must be in [0, 1]"),
            std::string::npos);
  EXPECT_NE(errorOf(ego + "ins_error: {position_std: -0.01}\n").find("ins_error: position_std must be >= 0"),
            std::string::npos);
  EXPECT_NE(errorOf(ego + "ins_error: {yaw_drift: 0.01}\n").find("ins_error: unknown key 'yaw_drift'"),
            std::string::npos);
  EXPECT_NE(
      errorOf(ego + "ins_error: {roll_std: [1]}\n").find("ins_error: key 'roll_std' has the wrong type"),
      std::string::npos);
}

}  // namespace grid_vision_fusion
