// Unit tests of the motion model (interacting multiple model of a stationary and a constant-
// velocity model, with the grid's evidence): standing and moving objects from their centres,
// jumps of the centre estimate of moving and standing objects, a stop, the grid's share and
// velocity, a centre cut along the object's length, the combined state, validation.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <stdexcept>

#include "grid_vision_fusion/fusion/motion_model.h"

namespace grid_vision_fusion
{
namespace
{
constexpr double kDt = 0.1;

/// Runs the model over the centres `x(k)`, y = 0, k = 1..n after a start at x(0); returns the
/// first image (from 1) at which the mode probability passed 0.5 the way `dynamic` says, or −1.
template <typename Position>
int firstImage(MotionModel& model, int n, Position x, bool dynamic)
{
  model.start(Eigen::Vector2d(x(0), 0.0), 0.5);
  for (int k = 1; k <= n; ++k)
  {
    model.predict(kDt);
    model.update(Eigen::Vector2d(x(k), 0.0));
    if ((model.modeProbability() > 0.5) == dynamic)
    {
      return k;
    }
  }
  return -1;
}

GridMotionEvidence share(double dynamic_share)
{
  GridMotionEvidence grid;
  grid.dynamic_share = dynamic_share;
  return grid;
}
}  // namespace

TEST(MotionModel, AStandingObjectBecomesStatic)
{
  MotionModel model;
  EXPECT_EQ(firstImage(
                model, 20, [](int) { return 10.0; }, false),
            1);
  for (int k = 0; k < 30; ++k)
  {
    model.predict(kDt);
    model.update(Eigen::Vector2d(10.0, 0.0));
  }
  EXPECT_LT(model.modeProbability(), 0.1);
  EXPECT_NEAR(model.state()(0), 10.0, 1e-6);
}

TEST(MotionModel, ANoisyStandingObjectStaysStatic)
{
  // Centre jitter of ±0.1 m (less than a cell), and one jump of 1 m that comes back.
  MotionModel model;
  model.start(Eigen::Vector2d(10.0, 0.0), 0.5);
  for (int k = 1; k <= 60; ++k)
  {
    model.predict(kDt);
    const double x = 10.0 + 0.1 * std::sin(2.3 * k) + (k == 30 ? 1.0 : 0.0);
    model.update(Eigen::Vector2d(x, 0.05 * std::cos(1.7 * k)));
    if (k >= 5)
    {
      EXPECT_LT(model.modeProbability(), 0.5) << "image " << k;
    }
  }
}

TEST(MotionModel, MoversAreFoundFasterTheFasterTheyGo)
{
  MotionModel model;
  const int car = firstImage(
      model, 30, [](int k) { return 10.0 + 1.0 * k; }, true);  // 10 m/s
  const int cyclist = firstImage(
      model, 30, [](int k) { return 10.0 + 0.4 * k; }, true);  // 4 m/s
  const int pedestrian = firstImage(
      model, 30, [](int k) { return 10.0 + 0.14 * k; }, true);  // 1.4 m/s
  EXPECT_GT(car, 0);
  EXPECT_LE(car, 2);
  EXPECT_GT(cyclist, 0);
  EXPECT_LE(cyclist, 3);
  EXPECT_GT(pedestrian, 0);
  EXPECT_LE(pedestrian, 6);
  EXPECT_LE(car, cyclist);
  EXPECT_LE(cyclist, pedestrian);
}

TEST(MotionModel, AStopIsSeen)
{
  // A car at 5 m/s for 3 s, then standing: static within 1 s of the stop.
  MotionModel model;
  model.start(Eigen::Vector2d(0.0, 0.0), 0.5);
  double x = 0.0;
  for (int k = 1; k <= 30; ++k)
  {
    model.predict(kDt);
    model.update(Eigen::Vector2d(x += 0.5, 0.0));
  }
  EXPECT_GT(model.modeProbability(), 0.99);
  EXPECT_NEAR(model.movingVelocity().x(), 5.0, 0.2);
  int stopped = -1;
  for (int k = 1; k <= 20 && stopped < 0; ++k)
  {
    model.predict(kDt);
    model.update(Eigen::Vector2d(x, 0.0));
    stopped = model.modeProbability() < 0.5 ? k : -1;
  }
  EXPECT_GT(stopped, 0);
  EXPECT_LE(stopped, 10);
}

TEST(MotionModel, TheGridsShareMovesTheProbability)
{
  MotionModel model;
  auto with = [&](double dynamic_share)
  {
    MotionEvidence evidence;
    evidence.grid = model.updateGrid(share(dynamic_share));
    return model.pDynamic(evidence);
  };
  model.start(Eigen::Vector2d(10.0, 0.0), 0.5);
  EXPECT_DOUBLE_EQ(with(0.5), 0.5) << "a share of one half says nothing";
  EXPECT_NEAR(with(1.0), 0.95, 1e-12) << "1 − grid_error";
  EXPECT_NEAR(with(0.0), 0.05, 1e-12);
  EXPECT_GT(with(0.8), with(0.6));
  EXPECT_DOUBLE_EQ(with(std::nan("")), 0.5);
  // The grid's word adds to the centres': a standing object stays static where its cells lean
  // dynamic a little.
  for (int k = 0; k < 20; ++k)
  {
    model.predict(kDt);
    model.update(Eigen::Vector2d(10.0, 0.0));
  }
  EXPECT_DOUBLE_EQ(model.pDynamic(MotionEvidence()), model.modeProbability())
      << "no evidence besides the centres";
  EXPECT_LT(with(0.7), 0.5);
}

TEST(MotionModel, TheGridsVelocityCountsByItsSpread)
{
  // A new object whose cells agree on 4 m/s with a spread of 0.5 m/s: dynamic at once (against
  // the prior speed_sigma of 3 m/s, one image of it), and the constant-velocity model takes the
  // velocity. The same velocity with the spread of a static
  // cell's scattered particles (5 m/s): little evidence, little velocity.
  MotionModel model;
  model.start(Eigen::Vector2d(10.0, 0.0), 0.5);
  GridMotionEvidence grid = share(0.5);
  grid.has_velocity = true;
  grid.velocity = Eigen::Vector2d(4.0, 0.0);
  grid.velocity_variance = Eigen::Vector2d(0.25, 0.25);
  EXPECT_GT(model.pDynamic({model.updateGrid(grid), 0.0}), 0.7);
  EXPECT_NEAR(model.movingVelocity().x(), 4.0, 0.3);
  MotionModel scattered;
  scattered.start(Eigen::Vector2d(10.0, 0.0), 0.5);
  grid.velocity_variance = Eigen::Vector2d(25.0, 25.0);
  EXPECT_LT(std::abs(scattered.pDynamic({scattered.updateGrid(grid), 0.0}) - 0.5), 0.2);
  EXPECT_LT(scattered.movingVelocity().x(), 1.0);
}

TEST(MotionModel, AGridVelocityIsJudgedBeforeItIsTakenIn)
{
  // A standing object whose cells show a spurious −3 m/s for one image (the smear of a passing
  // scan): judged against the velocity the model predicted (zero), it is no evidence of motion,
  // although the constant-velocity model takes it in afterwards.
  MotionModel model;
  model.start(Eigen::Vector2d(20.0, -5.0), 0.5);
  for (int k = 0; k < 20; ++k)
  {
    model.predict(kDt);
    model.update(Eigen::Vector2d(20.0, -5.0));
    (void)model.updateGrid(share(0.1));
  }
  model.predict(kDt);
  model.update(Eigen::Vector2d(20.0, -5.0));
  GridMotionEvidence smear = share(0.5);
  smear.has_velocity = true;
  smear.velocity = Eigen::Vector2d(-3.0, 0.0);
  smear.velocity_variance = Eigen::Vector2d(4.0, 4.0);
  EXPECT_LT(model.pDynamic({model.updateGrid(smear), 0.0}), 0.5);
  EXPECT_LT(model.movingVelocity().x(), -0.1) << "the velocity is taken in";
}

TEST(MotionModel, ACentreCutAlongTheLengthSaysNothingAlongIt)
{
  // A standing car whose centre slides along its length (x) by 0.2 m per image, the offset
  // bound growing with it: static, and its position stays. Across the length (y) the same slide
  // is a motion.
  for (const bool along : {true, false})
  {
    MotionModel model;
    model.start(Eigen::Vector2d(10.0, 0.0), 0.5);
    for (int k = 0; k < 20; ++k)
    {
      model.predict(kDt);
      model.update(Eigen::Vector2d(10.0, 0.0));
    }
    for (int k = 1; k <= 12; ++k)
    {
      model.predict(kDt);
      const Eigen::Vector2d centre =
          along ? Eigen::Vector2d(10.0 + 0.2 * k, 0.0) : Eigen::Vector2d(10.0, 0.2 * k);
      const double offset = 0.4 * k;
      model.update(centre, offset * offset * Eigen::Vector2d::UnitX() * Eigen::Vector2d::UnitX().transpose());
    }
    if (along)
    {
      EXPECT_LT(model.modeProbability(), 0.5);
      EXPECT_NEAR(model.state()(0), 10.0, 0.5);
    }
    else
    {
      EXPECT_GT(model.modeProbability(), 0.5);
    }
  }
}

TEST(MotionModel, ARestartKeepsTheMotion)
{
  // A car at 5 m/s whose centre estimate jumps 3 m ahead (its visible part changed): restarted
  // there, it keeps its velocity and P(dynamic), and goes on being dynamic.
  MotionModel model;
  model.start(Eigen::Vector2d(0.0, 0.0), 0.5);
  for (int k = 1; k <= 20; ++k)
  {
    model.predict(kDt);
    model.update(Eigen::Vector2d(0.5 * k, 0.0));
  }
  const double before = model.modeProbability();
  ASSERT_GT(before, 0.9);
  model.restartAt(Eigen::Vector2d(13.0, 0.0));
  EXPECT_DOUBLE_EQ(model.modeProbability(), before);
  EXPECT_NEAR(model.movingVelocity().x(), 5.0, 0.3);
  // The constant-velocity model is at the new centre, the stationary one halfway back to the
  // centre before the 3 m jump.
  EXPECT_NEAR(model.state()(0), 13.0 - (1.0 - before) * 1.5, 0.1);
  model.predict(kDt);
  model.update(Eigen::Vector2d(13.5, 0.0));
  EXPECT_GT(model.modeProbability(), 0.9);
}

TEST(MotionModel, ARestartForgetsHowSureTheVelocityWas)
{
  // Two cars cross in opposite directions at 10 m/s. When the near one hides the far one, the far
  // car's track takes the near car's centre 3.5 m away and restarts there. It keeps its +10 m/s
  // as a guess, not as a certainty: the near car's centres, going the other way, stay dynamic.
  MotionModel model;
  model.start(Eigen::Vector2d(21.6, -6.0), 0.5);
  for (int k = 1; k <= 10; ++k)
  {
    model.predict(kDt);
    model.update(Eigen::Vector2d(21.6, -6.0 + 1.0 * k));
  }
  ASSERT_GT(model.modeProbability(), 0.9);
  // The standard deviation of its speed, along y.
  auto speed_sigma = [&] { return std::sqrt(model.movingVelocityCovariance()(1, 1)); };
  ASSERT_LT(speed_sigma(), 1.0);
  model.restartAt(Eigen::Vector2d(18.2, 4.0));
  EXPECT_NEAR(speed_sigma(), MotionModelConfig().speed_sigma, 1e-9);
  EXPECT_NEAR(model.movingVelocity().y(), 10.0, 0.5);
  for (int k = 1; k <= 6; ++k)
  {
    model.predict(kDt);
    model.update(Eigen::Vector2d(18.2, 4.0 - 1.0 * k));
    SCOPED_TRACE(k);
    EXPECT_GT(model.modeProbability(), 0.5);
  }
  EXPECT_NEAR(model.movingVelocity().y(), -10.0, 1.0);
}

TEST(MotionModel, AStandingObjectWhoseCentreJumpsAndReturnsStaysStatic)
{
  // A parked car's cluster takes a passing cyclist's cells for one image: its centre jumps 2 m,
  // beyond the gate, and the track restarts there; then it is back. The stationary model kept
  // the place before the jump as likely as the new one: the returning centres fit it, and the
  // car stays static where it stands.
  MotionModel model;
  model.start(Eigen::Vector2d(20.0, 3.0), 0.5);
  for (int k = 1; k <= 20; ++k)
  {
    model.predict(kDt);
    model.update(Eigen::Vector2d(20.0 + (k % 2 == 0 ? 0.05 : -0.05), 3.0));
  }
  ASSERT_LT(model.modeProbability(), 0.2);
  model.predict(kDt);
  model.restartAt(Eigen::Vector2d(22.0, 3.4));
  for (int k = 1; k <= 6; ++k)
  {
    model.predict(kDt);
    model.update(Eigen::Vector2d(20.0, 3.0));
    SCOPED_TRACE(k);
    EXPECT_LT(model.modeProbability(), 0.5);
  }
  EXPECT_NEAR(model.state()(0), 20.0, 0.1);
  EXPECT_NEAR(model.state()(1), 3.0, 0.1);
}

TEST(MotionModel, TheCombinedStateWeighsTheModels)
{
  MotionModel model;
  model.start(Eigen::Vector2d(3.0, -2.0), 0.25);
  EXPECT_DOUBLE_EQ(model.modeProbability(), 0.25);
  EXPECT_TRUE(model.state().isApprox(Eigen::Vector4d(3.0, -2.0, 0.0, 0.0)));
  const Eigen::Matrix4d p = model.covariance();
  EXPECT_TRUE(p.isApprox(p.transpose()));
  EXPECT_GT(p(2, 2), 0.0);
  const Eigen::Matrix2d noise = 0.15 * 0.15 * Eigen::Matrix2d::Identity();
  EXPECT_DOUBLE_EQ(model.distance2(Eigen::Vector2d(3.0, -2.0), noise), 0.0);
  EXPECT_GT(model.distance2(Eigen::Vector2d(4.0, -2.0), noise), 0.0);
  model.predict(0.0);  // no time: nothing changes
  EXPECT_DOUBLE_EQ(model.modeProbability(), 0.25);
  const double v = MotionModelConfig{}.speed_sigma * MotionModelConfig{}.speed_sigma;
  EXPECT_TRUE(model.movingVelocityCovariance().isApprox(v * Eigen::Matrix2d::Identity()));
}

TEST(MotionModel, LogCauchyIsTheBivariateStudentTWithOneDegreeOfFreedom)
{
  const Eigen::Matrix2d unit = Eigen::Matrix2d::Identity();
  EXPECT_NEAR(logCauchy2(Eigen::Vector2d::Zero(), unit), -std::log(2.0 * M_PI), 1e-12);
  EXPECT_NEAR(logCauchy2(Eigen::Vector2d(1.0, 0.0), unit), -std::log(2.0 * M_PI) - 1.5 * std::log(2.0),
              1e-12);
  // Scaling the matrix by s² divides the density at the scaled point by s².
  EXPECT_NEAR(logCauchy2(Eigen::Vector2d(2.0, 0.0), 4.0 * unit),
              logCauchy2(Eigen::Vector2d(1.0, 0.0), unit) - std::log(4.0), 1e-12);
}

TEST(MotionModel, ConfigValidation)
{
  EXPECT_NO_THROW(MotionModelConfig{}.validate());
  auto bad = [](auto change)
  {
    MotionModelConfig c;
    change(c);
    return c;
  };
  EXPECT_THROW(MotionModel(bad([](MotionModelConfig& c) { c.position_sigma = 0.0; })), std::invalid_argument);
  EXPECT_THROW(MotionModel(bad([](MotionModelConfig& c) { c.acceleration_sigma = -1.0; })),
               std::invalid_argument);
  EXPECT_THROW(MotionModel(bad([](MotionModelConfig& c) { c.speed_sigma = std::nan(""); })),
               std::invalid_argument);
  EXPECT_THROW(
      MotionModel(bad([](MotionModelConfig& c) { c.switch_time = std::numeric_limits<double>::infinity(); })),
      std::invalid_argument);
  EXPECT_THROW(MotionModel(bad([](MotionModelConfig& c) { c.grid_error = 0.0; })), std::invalid_argument);
  try
  {
    MotionModel(bad([](MotionModelConfig& c) { c.grid_error = 0.7; }));
    FAIL() << "no exception";
  }
  catch (const std::invalid_argument& e)
  {
    EXPECT_NE(std::string(e.what()).find("motion_grid_error"), std::string::npos) << e.what();
  }
  MotionModel model;
  EXPECT_THROW(model.setConfig(bad([](MotionModelConfig& c) { c.switch_time = -1.0; })),
               std::invalid_argument);
  EXPECT_DOUBLE_EQ(model.config().switch_time, MotionModelConfig{}.switch_time);
}

}  // namespace grid_vision_fusion
