#include "grid_vision_fusion/fusion/assignment.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace grid_vision_fusion
{
namespace
{
/// Hungarian method on a dense n × m matrix `a` (row-major, n <= m, every entry finite):
/// returns the column of every row in a minimum-cost assignment that assigns every row.
std::vector<std::size_t> hungarian(const std::vector<double>& a, std::size_t n, std::size_t m)
{
  const double inf = std::numeric_limits<double>::infinity();
  // 1-based potentials and matching as in the textbook form; column 0 is a virtual start.
  std::vector<double> u(n + 1, 0.0), v(m + 1, 0.0);
  std::vector<std::size_t> row_of(m + 1, 0), way(m + 1, 0);
  for (std::size_t i = 1; i <= n; ++i)
  {
    row_of[0] = i;
    std::size_t j0 = 0;
    std::vector<double> min_slack(m + 1, inf);
    std::vector<bool> used(m + 1, false);
    do
    {
      used[j0] = true;
      const std::size_t i0 = row_of[j0];
      double delta = inf;
      std::size_t j1 = 0;
      for (std::size_t j = 1; j <= m; ++j)
      {
        if (used[j])
        {
          continue;
        }
        const double slack = a[(i0 - 1) * m + (j - 1)] - u[i0] - v[j];
        if (slack < min_slack[j])
        {
          min_slack[j] = slack;
          way[j] = j0;
        }
        if (min_slack[j] < delta)
        {
          delta = min_slack[j];
          j1 = j;
        }
      }
      for (std::size_t j = 0; j <= m; ++j)
      {
        if (used[j])
        {
          u[row_of[j]] += delta;
          v[j] -= delta;
        }
        else
        {
          min_slack[j] -= delta;
        }
      }
      j0 = j1;
    } while (row_of[j0] != 0);
    do
    {
      const std::size_t j1 = way[j0];
      row_of[j0] = row_of[j1];
      j0 = j1;
    } while (j0 != 0);
  }
  std::vector<std::size_t> col_of(n, kUnassigned);
  for (std::size_t j = 1; j <= m; ++j)
  {
    if (row_of[j] != 0)
    {
      col_of[row_of[j] - 1] = j - 1;
    }
  }
  return col_of;
}
}  // namespace

std::vector<std::size_t> solveAssignment(const CostMatrix& matrix)
{
  if (matrix.cost.size() != matrix.rows * matrix.cols)
  {
    throw std::invalid_argument("cost matrix holds " + std::to_string(matrix.cost.size()) + " values, not " +
                                std::to_string(matrix.rows) + " x " + std::to_string(matrix.cols));
  }
  std::vector<std::size_t> result(matrix.rows, kUnassigned);
  if (matrix.rows == 0 || matrix.cols == 0)
  {
    return result;
  }
  double largest = 0.0;
  bool any_allowed = false;
  for (double c : matrix.cost)
  {
    if (std::isnan(c) || c < 0.0)
    {
      throw std::invalid_argument("assignment costs must be >= 0 or kForbiddenCost, got " +
                                  std::to_string(c));
    }
    if (c != kForbiddenCost)
    {
      largest = std::max(largest, c);
      any_allowed = true;
    }
  }
  if (!any_allowed)
  {
    return result;
  }
  // A forbidden pair costs more than any set of allowed pairs together, so the minimum first
  // avoids forbidden pairs (the most allowed pairs), then minimises the cost of the allowed ones.
  const bool transpose = matrix.rows > matrix.cols;
  const std::size_t n = transpose ? matrix.cols : matrix.rows;
  const std::size_t m = transpose ? matrix.rows : matrix.cols;
  const double forbidden = (largest + 1.0) * static_cast<double>(n + 1);
  std::vector<double> a(n * m);
  for (std::size_t i = 0; i < n; ++i)
  {
    for (std::size_t j = 0; j < m; ++j)
    {
      const double c = transpose ? matrix.at(j, i) : matrix.at(i, j);
      a[i * m + j] = c == kForbiddenCost ? forbidden : c;
    }
  }
  const std::vector<std::size_t> col_of = hungarian(a, n, m);
  for (std::size_t i = 0; i < n; ++i)
  {
    const std::size_t j = col_of[i];
    const std::size_t row = transpose ? j : i;
    const std::size_t col = transpose ? i : j;
    if (j != kUnassigned && matrix.at(row, col) != kForbiddenCost)
    {
      result[row] = col;
    }
  }
  return result;
}

}  // namespace grid_vision_fusion
