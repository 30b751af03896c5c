// Unit tests of the scan registration of an object's lidar hits: the overlap per lattice shift,
// the likelihood ratio of moving against standing it gives (a shape that stays, a shape that
// moves as predicted, a side revealed further), bad input, and the motion model taking it in.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <vector>

#include "grid_vision_fusion/fusion/motion_model.h"
#include "grid_vision_fusion/fusion/scan_registration.h"

namespace grid_vision_fusion
{
namespace
{
constexpr double kCell = 0.2;

/// The hits of a car's rear face (along y, 9 cells) and its left side (along x, `side` cells) on
/// the 0.2 m lattice, the corner at (x0, y0) shifted by (dx, dy) cells.
std::vector<Eigen::Vector2d> carCorner(int side, int dx = 0, int dy = 0, double x0 = 10.1, double y0 = 2.1)
{
  std::vector<Eigen::Vector2d> hits;
  for (int j = 0; j < 9; ++j)
  {
    hits.emplace_back(x0 + dx * kCell, y0 + (dy + j) * kCell);
  }
  for (int i = 1; i <= side; ++i)
  {
    hits.emplace_back(x0 + (dx + i) * kCell, y0 + dy * kCell);
  }
  return hits;
}

}  // namespace

TEST(ShiftVotes, CountsTheHitsEachShiftExplains)
{
  const std::vector<Eigen::Vector2d> then = carCorner(10);
  const ShiftVotes votes(then, carCorner(10, 3, -1), kCell, 5.0);
  EXPECT_EQ(votes.overlap(3, -1), 19);
  EXPECT_EQ(votes.maxOverlap(), 19);
  EXPECT_LT(votes.overlap(0, 0), 3);
  EXPECT_EQ(votes.overlap(std::numeric_limits<int>::max(), std::numeric_limits<int>::min()), 0);

  // Positions off the lattice by less than half a cell (a dynamic cell moved to the image stamp)
  // still vote for their shift.
  std::vector<Eigen::Vector2d> jittered = carCorner(10, 3, -1);
  for (Eigen::Vector2d& p : jittered)
  {
    p += Eigen::Vector2d(0.07, -0.05);
  }
  EXPECT_EQ(ShiftVotes(then, jittered, kCell, 5.0).overlap(3, -1), 19);

  // Shifts beyond max_shift are not counted.
  EXPECT_EQ(ShiftVotes(then, carCorner(10, 60, 0), kCell, 5.0).maxOverlap(), 0);
  EXPECT_EQ(ShiftVotes(then, carCorner(10, 60, 0), kCell, 13.0).overlap(60, 0), 19);
}

TEST(ShiftVotes, BadInputGivesNoVotes)
{
  const std::vector<Eigen::Vector2d> hits = carCorner(5);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(ShiftVotes(hits, hits, 0.0, 5.0).maxOverlap(), 0);
  EXPECT_EQ(ShiftVotes(hits, hits, -0.2, 5.0).maxOverlap(), 0);
  EXPECT_EQ(ShiftVotes(hits, hits, nan, 5.0).maxOverlap(), 0);
  EXPECT_EQ(ShiftVotes(hits, hits, kCell, nan).maxOverlap(), 0);
  EXPECT_EQ(ShiftVotes({}, hits, kCell, 5.0).maxOverlap(), 0);
  // Fewer than kMinHits in either scan say nothing of a shape.
  const std::vector<Eigen::Vector2d> two(hits.begin(), hits.begin() + 2);
  EXPECT_EQ(ShiftVotes(two, hits, kCell, 5.0).maxOverlap(), 0);
  EXPECT_EQ(ShiftVotes(hits, two, kCell, 5.0).maxOverlap(), 0);
  const std::vector<Eigen::Vector2d> three(hits.begin(), hits.begin() + 3);
  EXPECT_EQ(ShiftVotes(three, hits, kCell, 5.0).maxOverlap(), 3);
  // Too many pairs to count in bounded time: no votes, no evidence.
  std::vector<Eigen::Vector2d> wall;
  for (int i = 0; i < 401; ++i)
  {
    wall.emplace_back(30.1, -40.1 + kCell * i);
  }
  EXPECT_EQ(ShiftVotes(wall, wall, kCell, 5.0).maxOverlap(), 0);
  wall.pop_back();
  EXPECT_EQ(ShiftVotes(wall, wall, kCell, 5.0).maxOverlap(), 400);
  std::vector<Eigen::Vector2d> with_nan = hits;
  with_nan[0].x() = nan;
  EXPECT_EQ(ShiftVotes(hits, with_nan, kCell, 5.0).maxOverlap(), static_cast<int>(hits.size()) - 1);
  EXPECT_EQ(ShiftVotes(with_nan, hits, kCell, 5.0).maxOverlap(), static_cast<int>(hits.size()) - 1);
  EXPECT_EQ(registrationLogRatio(ShiftVotes({}, hits, kCell, 5.0), 0.3, Eigen::Vector2d(5.0, 0.0),
                                 Eigen::Matrix2d::Identity()),
            0.0);
}

TEST(ScanRegistration, AShapeThatStaysSaysStandingAndOneThatMovesSaysMoving)
{
  // The constant-velocity model believes in 5 m/s along x, give or take 1 m/s; 0.3 s apart.
  const Eigen::Vector2d velocity(5.0, 0.0);
  const Eigen::Matrix2d cov = Eigen::Matrix2d::Identity();
  const double stays =
      registrationLogRatio(ShiftVotes(carCorner(10), carCorner(10), kCell, 5.0), 0.3, velocity, cov);
  EXPECT_LT(stays, -3.0);
  // Moved by 1.4 m (7 cells): as predicted.
  const double moves =
      registrationLogRatio(ShiftVotes(carCorner(10), carCorner(10, 7, 0), kCell, 5.0), 0.3, velocity, cov);
  EXPECT_GT(moves, 3.0);
  // A side revealed further (a parked car a passing truck uncovers) while its rear face stays:
  // standing, whatever its centre does.
  EXPECT_LT(registrationLogRatio(ShiftVotes(carCorner(4), carCorner(12), kCell, 5.0), 0.3, velocity, cov),
            -3.0);
  // Without time or velocity, no evidence.
  EXPECT_EQ(registrationLogRatio(ShiftVotes(carCorner(10), carCorner(10), kCell, 5.0), 0.0, velocity, cov),
            0.0);
  EXPECT_EQ(registrationLogRatio(ShiftVotes(carCorner(10), carCorner(10), kCell, 5.0), 0.3,
                                 Eigen::Vector2d(std::numeric_limits<double>::quiet_NaN(), 0.0), cov),
            0.0);
}

TEST(ScanRegistration, WhatTheHitsCannotShowSaysNothing)
{
  // A long texture-less side along x (a bus's, 25 cells) seen through a window that slides 1 m
  // (5 cells) along it in 0.3 s, as the image edge cuts it while the ego passes: the window's
  // shift explains every hit and reads as motion. Told that the hits cannot show a displacement
  // along x (2.5 m, a hidden half of its length), the registration weighs only the displacement
  // across the side, which is none: standing.
  auto side = [](int from)
  {
    std::vector<Eigen::Vector2d> hits;
    for (int i = 0; i < 25; ++i)
    {
      hits.emplace_back(8.1 + kCell * (from + i), 4.1);
    }
    return hits;
  };
  // The constant-velocity model has taken the sliding centre's 3.3 m/s along x.
  const Eigen::Vector2d velocity(3.3, 0.0);
  const Eigen::Matrix2d cov = Eigen::Matrix2d::Identity();
  EXPECT_GT(registrationLogRatio(side(0), side(5), kCell, 0.3, velocity, cov), 2.0);
  Eigen::Matrix2d along_x = Eigen::Matrix2d::Zero();
  along_x(0, 0) = 2.5 * 2.5;
  EXPECT_LT(registrationLogRatio(side(0), side(5), kCell, 0.3, velocity, cov, along_x), -1.0);
  // A side that moves across itself still says moving.
  std::vector<Eigen::Vector2d> across = side(5);
  for (Eigen::Vector2d& hit : across)
  {
    hit.y() += 5 * kCell;
  }
  EXPECT_GT(registrationLogRatio(side(0), across, kCell, 0.3, velocity, cov, along_x), 3.0);
  // A covariance that is not finite gives no evidence.
  along_x(0, 0) = std::numeric_limits<double>::infinity();
  EXPECT_EQ(registrationLogRatio(side(0), side(5), kCell, 0.3, velocity, cov, along_x), 0.0);
}

TEST(MotionModel, OneRegistrationMovesTheOddsAtMostByTheGridsErrorRate)
{
  // 19 hits shifted by 7 cells: alone, many nats for moving. Its vote errs like the grid's, so from
  // even odds it gives P(dynamic) up to 1 − ε, and a shape that stays down to ε, no further.
  for (const double error : {0.05, 0.2})
  {
    MotionModelConfig config;
    config.grid_error = error;
    MotionModel moves(config);
    moves.start(Eigen::Vector2d(10.5, 2.9), 0.5);
    const double p_moves =
        moves.pDynamic({0.0, moves.registrationEvidence(carCorner(10), carCorner(10, 7, 0), kCell, 0.3)});
    EXPECT_LE(p_moves, 1.0 - error);
    EXPECT_GT(p_moves, 1.0 - error - 0.01);
    MotionModel stays(config);
    stays.start(Eigen::Vector2d(10.5, 2.9), 0.5);
    const double p_stays =
        stays.pDynamic({0.0, stays.registrationEvidence(carCorner(10), carCorner(10), kCell, 0.3)});
    EXPECT_GE(p_stays, error);
    EXPECT_LT(p_stays, error + 0.01);
  }
}

TEST(MotionModel, TheHitsRegistrationKeepsARevealedStandingObjectStatic)
{
  // A parked car uncovered by a passing truck: its side is revealed by 3 cells per image and
  // its centre estimate slides 0.3 m per image with the visible part, which the centres take for
  // motion, more strongly than the grid's static cells say standing. Its rear face is hit at the
  // same place in every scan.
  GridMotionEvidence static_cells;
  static_cells.dynamic_share = 0.1;
  auto run = [&static_cells](bool registration)
  {
    MotionModel model;
    model.start(Eigen::Vector2d(10.5, 2.9), 0.5);
    std::vector<std::vector<Eigen::Vector2d>> hits{carCorner(2)};
    double p = 0.0;
    for (int k = 1; k <= 6; ++k)
    {
      model.predict(0.1);
      model.update(Eigen::Vector2d(10.5 + 0.3 * k, 2.9));
      MotionEvidence evidence;
      evidence.grid = model.updateGrid(static_cells);
      hits.push_back(carCorner(2 + 3 * k));
      if (registration)
      {
        const std::size_t then = hits.size() >= 4 ? hits.size() - 4 : 0;
        evidence.registration = model.registrationEvidence(hits[then], hits.back(), kCell,
                                                           0.1 * static_cast<double>(hits.size() - 1 - then));
      }
      p = std::max(p, model.pDynamic(evidence));
    }
    return p;
  };
  EXPECT_GT(run(false), 0.5) << "the centres and the grid take the revealed side for motion";
  EXPECT_LT(run(true), 0.5);
}

TEST(MotionModel, TheHitsRegistrationConfirmsAMover)
{
  // A car moving at 2 m/s: its hits shift by a cell per image and its centre with them.
  MotionModel with;
  MotionModel without;
  with.start(Eigen::Vector2d(10.5, 2.9), 0.5);
  without.start(Eigen::Vector2d(10.5, 2.9), 0.5);
  std::vector<std::vector<Eigen::Vector2d>> hits{carCorner(10)};
  MotionEvidence evidence;
  for (int k = 1; k <= 4; ++k)
  {
    for (MotionModel* model : {&with, &without})
    {
      model->predict(0.1);
      model->update(Eigen::Vector2d(10.5 + 0.2 * k, 2.9));
    }
    hits.push_back(carCorner(10, k, 0));
    const std::size_t then = hits.size() >= 4 ? hits.size() - 4 : 0;
    evidence.registration = with.registrationEvidence(hits[then], hits.back(), kCell,
                                                      0.1 * static_cast<double>(hits.size() - 1 - then));
  }
  EXPECT_GT(with.pDynamic(evidence), 0.9);
  EXPECT_GT(with.pDynamic(evidence), without.pDynamic(MotionEvidence()));
  EXPECT_DOUBLE_EQ(with.pDynamic(MotionEvidence()), with.modeProbability());
}

}  // namespace grid_vision_fusion
