// Unit tests of the optimal assignment (Hungarian method): hand-checked optima, rectangular and
// forbidden cases, and every small matrix of a fixed pseudo-random set against brute force.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <numeric>
#include <random>
#include <stdexcept>

#include "grid_vision_fusion/fusion/assignment.h"

namespace grid_vision_fusion
{
namespace
{
CostMatrix matrixOf(std::size_t rows, std::size_t cols, const std::vector<double>& values)
{
  CostMatrix m(rows, cols);
  m.cost = values;
  return m;
}

/// (number of assigned pairs, their total cost) of an assignment.
std::pair<std::size_t, double> score(const CostMatrix& m, const std::vector<std::size_t>& assignment)
{
  std::size_t pairs = 0;
  double total = 0.0;
  std::vector<bool> used(m.cols, false);
  for (std::size_t r = 0; r < m.rows; ++r)
  {
    const std::size_t c = assignment[r];
    if (c == kUnassigned)
    {
      continue;
    }
    EXPECT_LT(c, m.cols);
    EXPECT_FALSE(used[c]) << "column " << c << " assigned twice";
    EXPECT_NE(m.at(r, c), kForbiddenCost) << "a forbidden pair was assigned";
    used[c] = true;
    ++pairs;
    total += m.at(r, c);
  }
  return {pairs, total};
}

/// The best (most pairs, then least cost) over every injective partial assignment.
std::pair<std::size_t, double> bruteForce(const CostMatrix& m)
{
  std::pair<std::size_t, double> best{0, 0.0};
  std::vector<std::size_t> assignment(m.rows, kUnassigned);
  std::vector<bool> used(m.cols, false);
  std::function<void(std::size_t, std::size_t, double)> visit =
      [&](std::size_t r, std::size_t pairs, double total)
  {
    if (r == m.rows)
    {
      if (pairs > best.first || (pairs == best.first && total < best.second - 1e-12))
      {
        best = {pairs, total};
      }
      return;
    }
    visit(r + 1, pairs, total);  // row r unassigned
    for (std::size_t c = 0; c < m.cols; ++c)
    {
      if (!used[c] && m.at(r, c) != kForbiddenCost)
      {
        used[c] = true;
        visit(r + 1, pairs + 1, total + m.at(r, c));
        used[c] = false;
      }
    }
  };
  visit(0, 0, 0.0);
  return best;
}
}  // namespace

TEST(Assignment, SquareTextbookCase)
{
  // Row 0 -> 1 (1), row 1 -> 0 (2), row 2 -> 2 (2): total 5; every other permutation costs more
  // (e.g. 0->0, 1->1, 2->2: 4 + 0 + 2 = 6).
  const CostMatrix m = matrixOf(3, 3, {4, 1, 3, 2, 0, 5, 3, 2, 2});
  EXPECT_EQ(solveAssignment(m), (std::vector<std::size_t>{1, 0, 2}));
}

TEST(Assignment, RectangularBothWays)
{
  // Two rows, three columns: row 0 -> 2 (1), row 1 -> 0 (1).
  EXPECT_EQ(solveAssignment(matrixOf(2, 3, {5, 4, 1, 1, 3, 2})), (std::vector<std::size_t>{2, 0}));
  // Three rows, two columns: rows 1 and 2 take the columns (0.5 + 0.5), row 0 is left out.
  EXPECT_EQ(solveAssignment(matrixOf(3, 2, {3, 3, 0.5, 9, 9, 0.5})),
            (std::vector<std::size_t>{kUnassigned, 0, 1}));
}

TEST(Assignment, ForbiddenPairsAreNeverUsedAndTheMostPairsWin)
{
  const double x = kForbiddenCost;
  // Row 1 can only take column 0, so row 0 takes column 1 (2 + 1 = 3) although 0 -> 0 alone is
  // cheaper (1): as many allowed pairs as possible first.
  EXPECT_EQ(solveAssignment(matrixOf(2, 2, {1, 2, 1, x})), (std::vector<std::size_t>{1, 0}));
  EXPECT_EQ(solveAssignment(matrixOf(2, 2, {x, x, x, x})),
            (std::vector<std::size_t>{kUnassigned, kUnassigned}));
  EXPECT_EQ(solveAssignment(matrixOf(2, 2, {x, 3, x, x})), (std::vector<std::size_t>{1, kUnassigned}));
  EXPECT_TRUE(solveAssignment(CostMatrix(0, 4)).empty());
  EXPECT_EQ(solveAssignment(CostMatrix(2, 0)), (std::vector<std::size_t>{kUnassigned, kUnassigned}));
}

TEST(Assignment, EqualCostsAreResolvedInOrder)
{
  EXPECT_EQ(solveAssignment(matrixOf(2, 2, {1, 1, 1, 1})), solveAssignment(matrixOf(2, 2, {1, 1, 1, 1})));
  const std::vector<std::size_t> a = solveAssignment(matrixOf(2, 2, {1, 1, 1, 1}));
  EXPECT_NE(a[0], a[1]);
}

TEST(Assignment, MatchesBruteForceOnRandomMatrices)
{
  std::mt19937 random(12);
  std::uniform_real_distribution<double> cost(0.0, 10.0);
  std::uniform_int_distribution<int> size(1, 5);
  std::bernoulli_distribution forbidden(0.3);
  for (int trial = 0; trial < 400; ++trial)
  {
    CostMatrix m(static_cast<std::size_t>(size(random)), static_cast<std::size_t>(size(random)));
    for (double& c : m.cost)
    {
      c = forbidden(random) ? kForbiddenCost : std::round(cost(random) * 4.0) / 4.0;  // ties happen
    }
    const auto expected = bruteForce(m);
    const auto got = score(m, solveAssignment(m));
    ASSERT_EQ(got.first, expected.first) << "trial " << trial;
    ASSERT_NEAR(got.second, expected.second, 1e-9) << "trial " << trial;
  }
}

TEST(Assignment, RefusesBadInput)
{
  EXPECT_THROW(solveAssignment(matrixOf(2, 2, {1, 2, 3})), std::invalid_argument);
  EXPECT_THROW(solveAssignment(matrixOf(1, 2, {1, std::nan("")})), std::invalid_argument);
  EXPECT_THROW(solveAssignment(matrixOf(1, 2, {1, -1})), std::invalid_argument);
  EXPECT_THROW(solveAssignment(matrixOf(1, 1, {-std::numeric_limits<double>::infinity()})),
               std::invalid_argument);
}

}  // namespace grid_vision_fusion
