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
}

}  // namespace grid_vision_fusion
