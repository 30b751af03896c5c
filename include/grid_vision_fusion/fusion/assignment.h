// Optimal assignment (the Hungarian method) of rows to columns of a cost matrix with forbidden
// pairs, for the tracker's association of tracks and fused objects.
//
// Debian 12 has no maintained C++ library that fits: its Munkres packages are Perl and Python
// (libalgorithm-munkres-perl, python3-munkres), and dlib's max_cost_assignment (libdlib-dev)
// wants a square integer matrix and brings dlib onto the vehicle. This is the shortest
// augmenting path form of the Hungarian method with row and column potentials (Kuhn–Munkres as
// refined by Jonker and Volgenant), O(n² m) for n rows and m >= n columns.
#pragma once

#include <cstddef>
#include <limits>
#include <vector>

namespace grid_vision_fusion
{
/// The cost of a forbidden pair (outside the gate): such a pair is never assigned.
constexpr double kForbiddenCost = std::numeric_limits<double>::infinity();

/// A dense row-major cost matrix.
struct CostMatrix
{
  std::size_t rows = 0;
  std::size_t cols = 0;
  std::vector<double> cost;  ///< rows × cols, row-major; kForbiddenCost marks a forbidden pair

  CostMatrix() = default;
  /// A rows × cols matrix with every pair forbidden.
  CostMatrix(std::size_t r, std::size_t c) : rows(r), cols(c), cost(r * c, kForbiddenCost) {}
  double& at(std::size_t r, std::size_t c) { return cost[r * cols + c]; }
  double at(std::size_t r, std::size_t c) const { return cost[r * cols + c]; }
};

/// Marks a row or column without a partner in assignment results.
constexpr std::size_t kUnassigned = std::numeric_limits<std::size_t>::max();

/// The assignment of minimum total cost among those with the most allowed pairs: first as many
/// rows as possible get a column (forbidden pairs excluded), then the sum of the costs of the
/// assigned pairs is minimal. Returns, per row, its column or kUnassigned. Deterministic: equal
/// costs are resolved by row and column order.
/// @throws std::invalid_argument when the matrix size does not match rows × cols, or a cost is
///         NaN, negative infinity or negative.
std::vector<std::size_t> solveAssignment(const CostMatrix& matrix);

}  // namespace grid_vision_fusion
