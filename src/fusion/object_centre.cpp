#include "grid_vision_fusion/fusion/object_centre.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <sstream>
#include <stdexcept>
#include <unordered_map>

#include "grid_vision_fusion/fusion/model_constants.h"

namespace grid_vision_fusion
{
namespace
{

constexpr double kMinEdgeDistanceM = 0.05;  // closeness criterion: nearer points count as this near
constexpr double kCoarseStepRad = M_PI / 20.0;
constexpr double kFineStepRad = M_PI / 180.0;

/// The extent of the points (x[i], y[i]) (non-empty) along the axes a = (c, s) and b = (−s, c)
/// of a rectangle, and their mean along each.
struct AxisExtent
{
  double a_lo = std::numeric_limits<double>::infinity(), a_hi = -a_lo, b_lo = a_lo, b_hi = -a_lo;
  double a_mean = 0.0, b_mean = 0.0;
};

AxisExtent axisExtent(const std::vector<double>& x, const std::vector<double>& y, double c, double s)
{
  AxisExtent e;
  for (std::size_t i = 0; i < x.size(); ++i)
  {
    const double a = c * x[i] + s * y[i];
    const double b = -s * x[i] + c * y[i];
    e.a_lo = std::min(e.a_lo, a);
    e.a_hi = std::max(e.a_hi, a);
    e.b_lo = std::min(e.b_lo, b);
    e.b_hi = std::max(e.b_hi, b);
    e.a_mean += a;
    e.b_mean += b;
  }
  e.a_mean /= static_cast<double>(x.size());
  e.b_mean /= static_cast<double>(x.size());
  return e;
}

/// Closeness score of the bounding rectangle at orientation `theta` (higher is better).
double closeness(const std::vector<double>& x, const std::vector<double>& y, double theta)
{
  const double c = std::cos(theta);
  const double s = std::sin(theta);
  const AxisExtent e = axisExtent(x, y, c, s);
  double score = 0.0;
  for (std::size_t i = 0; i < x.size(); ++i)
  {
    const double a = c * x[i] + s * y[i];
    const double b = -s * x[i] + c * y[i];
    const double d = std::min(std::min(a - e.a_lo, e.a_hi - a), std::min(b - e.b_lo, e.b_hi - b));
    score += 1.0 / std::max(d, kMinEdgeDistanceM);
  }
  return score;
}

/// Union-find over point indices 0..n-1 (path halving, union by index: deterministic).
class DisjointSets
{
public:
  explicit DisjointSets(std::size_t n) : parent_(n) { std::iota(parent_.begin(), parent_.end(), 0U); }
  std::size_t find(std::size_t i)
  {
    while (parent_[i] != i)
    {
      parent_[i] = parent_[parent_[i]];
      i = parent_[i];
    }
    return i;
  }
  void unite(std::size_t a, std::size_t b)
  {
    a = find(a);
    b = find(b);
    if (a != b)
    {
      parent_[std::max(a, b)] = std::min(a, b);
    }
  }

private:
  std::vector<std::size_t> parent_;
};

/// Cluster label (the smallest member's index) of every point, single linkage at `distance`.
std::vector<std::size_t> clusterPoints(const std::vector<double>& x, const std::vector<double>& y,
                                       double distance)
{
  const std::size_t n = x.size();
  DisjointSets sets(n);
  // Buckets of side `distance`: linked points lie in the same or a neighbouring bucket.
  auto key = [distance](double px, double py)
  {
    const auto bx = static_cast<std::int64_t>(std::floor(px / distance));
    const auto by = static_cast<std::int64_t>(std::floor(py / distance));
    return std::make_pair(bx, by);
  };
  struct PairHash
  {
    std::size_t operator()(const std::pair<std::int64_t, std::int64_t>& k) const
    {
      return std::hash<std::int64_t>()(k.first * 73856093LL ^ k.second * 19349663LL);
    }
  };
  std::unordered_map<std::pair<std::int64_t, std::int64_t>, std::vector<std::size_t>, PairHash> buckets;
  buckets.reserve(n);
  for (std::size_t i = 0; i < n; ++i)
  {
    buckets[key(x[i], y[i])].push_back(i);
  }
  const double d2 = distance * distance;
  for (std::size_t i = 0; i < n; ++i)
  {
    const auto [bx, by] = key(x[i], y[i]);
    for (std::int64_t dx = -1; dx <= 1; ++dx)
    {
      for (std::int64_t dy = -1; dy <= 1; ++dy)
      {
        const auto bucket = buckets.find({bx + dx, by + dy});
        if (bucket == buckets.end())
        {
          continue;
        }
        for (std::size_t j : bucket->second)
        {
          if (j > i && (x[i] - x[j]) * (x[i] - x[j]) + (y[i] - y[j]) * (y[i] - y[j]) <= d2)
          {
            sets.unite(i, j);
          }
        }
      }
    }
  }
  std::vector<std::size_t> label(n);
  for (std::size_t i = 0; i < n; ++i)
  {
    label[i] = sets.find(i);
  }
  return label;
}

/// The centre coordinate along one axis: cells observed in [lo, hi], the camera at `camera`, the
/// object `dimension` long along it.
double axisCentre(double lo, double hi, double camera, double dimension)
{
  if (hi - lo >= dimension)
  {
    return 0.5 * (lo + hi);
  }
  if (camera < lo)
  {
    return lo + 0.5 * dimension;
  }
  if (camera > hi)
  {
    return hi - 0.5 * dimension;
  }
  return 0.5 * (lo + hi);
}

/// Steps 3.–4. of estimateCentre() on the cells (cx[i], cy[i]) (non-empty). `covers_more`
/// receives whether they extend beyond the footprint along an axis (false without one).
CentreEstimate centreOfCells(const std::vector<double>& cx, const std::vector<double>& cy, double camera_x,
                             double camera_y, const Footprint* footprint, bool& covers_more)
{
  CentreEstimate estimate;
  estimate.yaw = fitOrientation(cx, cy);
  const double c = std::cos(estimate.yaw);
  const double s = std::sin(estimate.yaw);
  const AxisExtent e = axisExtent(cx, cy, c, s);
  const double a_cam = c * camera_x + s * camera_y;
  const double b_cam = -s * camera_x + c * camera_y;
  double a_centre = 0.5 * (e.a_lo + e.a_hi);
  double b_centre = 0.5 * (e.b_lo + e.b_hi);
  if (footprint)
  {
    const double extent_a = e.a_hi - e.a_lo;
    const double extent_b = e.b_hi - e.b_lo;
    // Viewing direction in the outline's axes: the face along axis a is seen with weight |view_b|.
    double view_a = e.a_mean - a_cam;
    double view_b = e.b_mean - b_cam;
    const double norm = std::hypot(view_a, view_b);
    if (norm > 0.0)
    {
      view_a /= norm;
      view_b /= norm;
    }
    auto mismatch = [&](double along_a, double along_b)
    {
      return std::max(0.0, extent_a - along_a) + std::max(0.0, extent_b - along_b) +
             std::abs(view_b) * std::abs(extent_a - along_a) +
             std::abs(view_a) * std::abs(extent_b - along_b);
    };
    const bool length_along_a =
        mismatch(footprint->length, footprint->width) <= mismatch(footprint->width, footprint->length);
    const double dim_a = length_along_a ? footprint->length : footprint->width;
    const double dim_b = length_along_a ? footprint->width : footprint->length;
    covers_more = extent_a > dim_a || extent_b > dim_b;
    estimate.length = std::max(footprint->length, length_along_a ? extent_a : extent_b);
    a_centre = axisCentre(e.a_lo, e.a_hi, a_cam, dim_a);
    b_centre = axisCentre(e.b_lo, e.b_hi, b_cam, dim_b);
  }
  else
  {
    estimate.length = std::max(e.a_hi - e.a_lo, e.b_hi - e.b_lo);
    covers_more = false;
  }
  estimate.x = c * a_centre - s * b_centre;
  estimate.y = s * a_centre + c * b_centre;
  return estimate;
}

/// The bottom edge of a detection box and how far from it an image row lies, in the tolerances
/// of kBelowToleranceFraction, kAboveToleranceFraction and kBottomEdgeErrorFraction of the box's
/// height.
struct BottomEdge
{
  explicit BottomEdge(const BoundingBox& box)
      : y_max(box.y_max),
        height(std::max(static_cast<double>(box.height()), 1.0)),
        below_px(kBelowToleranceFraction * height),
        above_px(kAboveToleranceFraction * height)
  {
  }
  /// How far row `v` lies below the edge beyond the tolerance, in units of the tolerance.
  double belowBeyondTolerance(double v) const { return std::max(v - y_max - below_px, 0.0) / below_px; }
  /// How far row `v` lies above the edge beyond the tolerance, in units of the tolerance.
  double aboveBeyondTolerance(double v) const { return std::max(y_max - v - above_px, 0.0) / above_px; }
  /// How far row `v` lies above the edge, in units of the edge's error.
  double aboveInEdgeErrors(double v) const
  {
    return std::max(y_max - v, 0.0) / (kBottomEdgeErrorFraction * height);
  }

  double y_max;
  double height;
  double below_px;
  double above_px;
};

/// Scores within this of each other are a tie, broken by the lowest row (objectCluster()).
constexpr double kScoreTie = 1e-9;

/// How well one cluster of a fusion band fits the detection (higher is better).
struct ClusterScore
{
  double value = 0.0;
  float lowest_row = 0.F;  ///< the image row of its lowest cell: its nearest to the camera

  /// Whether this score wins over `other`: higher by more than kScoreTie, or tied and lower in
  /// the image (nearer).
  bool beats(const ClusterScore& other) const
  {
    return value > other.value + kScoreTie ||
           (std::abs(value - other.value) <= kScoreTie && lowest_row > other.lowest_row);
  }
};

/// What objectCluster() counts of one cluster of a fusion band, cell by cell.
struct ClusterTally
{
  double near_edge = 0.0;  ///< its cells, each weighted by how near its row lies to the bottom edge
  float lowest_row = -std::numeric_limits<float>::infinity();
  std::size_t cells = 0;
  std::size_t expected_cells = 0;  ///< of them, near a cell the detection's track expects

  /// Counts a cell at image row `v`, near a cell the track expects or not.
  void add(float v, const BottomEdge& edge, bool expected)
  {
    const double below = edge.belowBeyondTolerance(v);
    const double above = edge.aboveBeyondTolerance(v);
    near_edge += std::exp(-below * below - above * above);
    lowest_row = std::max(lowest_row, v);
    ++cells;
    expected_cells += expected ? 1 : 0;
  }

  /// The product of three factors: the cells near the bottom edge; up to twice that for a
  /// cluster that continues the track's (the share of its cells near an expected one); and how
  /// well its nearest cell meets the edge, the ground contact of the object's nearest part: a
  /// cluster whose nearest cell lies well above it stands behind the object (a wall behind a
  /// pedestrian), one whose nearest cell lies well below it stands in front.
  ClusterScore score(const BottomEdge& edge) const
  {
    double value = near_edge;
    value *= 1.0 + static_cast<double>(expected_cells) / static_cast<double>(cells);
    const double behind = edge.aboveInEdgeErrors(lowest_row);
    const double in_front = edge.belowBeyondTolerance(lowest_row);
    value *= std::exp(-0.5 * behind * behind - in_front * in_front);
    return {value, lowest_row};
  }
};

}  // namespace

void CentreConfig::validate() const
{
  if (max_scans_since_hit < -1 || max_scans_since_hit > 254)
  {
    throw std::invalid_argument("centre_max_scans_since_hit must be in [-1, 254], got " +
                                std::to_string(max_scans_since_hit));
  }
  if (!std::isfinite(cluster_distance) || cluster_distance <= 0.0)
  {
    throw std::invalid_argument("centre_cluster_distance must be a finite value > 0 m, got " +
                                std::to_string(cluster_distance));
  }
  for (const auto& [label, footprint] : footprints)
  {
    if (label.empty())
    {
      throw std::invalid_argument("class_footprints: a label is empty");
    }
    if (!std::isfinite(footprint.length) || footprint.length <= 0.0 || !std::isfinite(footprint.width) ||
        footprint.width <= 0.0)
    {
      std::ostringstream msg;
      msg << "class_footprints/" << label << ": length and width must be finite values > 0 m, got "
          << footprint.length << " x " << footprint.width;
      throw std::invalid_argument(msg.str());
    }
  }
}

double fitOrientation(const std::vector<double>& x, const std::vector<double>& y)
{
  if (x.size() < 3 || x.size() != y.size())
  {
    return 0.0;
  }
  double best_theta = 0.0;
  double best_score = -1.0;
  for (double theta = 0.0; theta < M_PI / 2.0 - 1e-9; theta += kCoarseStepRad)
  {
    const double score = closeness(x, y, theta);
    if (score > best_score)
    {
      best_score = score;
      best_theta = theta;
    }
  }
  const double coarse = best_theta;
  const int fine_steps = static_cast<int>(std::floor(0.5 * kCoarseStepRad / kFineStepRad + 1e-9));
  for (int k = -fine_steps; k <= fine_steps; ++k)
  {
    if (k == 0)
    {
      continue;
    }
    const double theta = coarse + k * kFineStepRad;
    const double score = closeness(x, y, theta);
    if (score > best_score)
    {
      best_score = score;
      best_theta = theta;
    }
  }
  // Back into [0, π/2): a rectangle at θ is the same as at θ ± π/2.
  best_theta = std::fmod(best_theta + M_PI / 2.0, M_PI / 2.0);
  return best_theta;
}

std::vector<std::uint32_t> objectCluster(const ProjectedPointsView& points,
                                         const std::vector<std::uint32_t>& members, const BoundingBox& box,
                                         double cluster_distance,
                                         const std::vector<Eigen::Vector2d>& expected)
{
  const std::size_t n = members.size();
  std::vector<double> xs(n), ys(n);
  for (std::size_t k = 0; k < n; ++k)
  {
    if (members[k] >= points.size)
    {
      throw std::invalid_argument("objectCluster: point index " + std::to_string(members[k]) +
                                  " outside the " + std::to_string(points.size) + " points");
    }
    xs[k] = points.x[members[k]];
    ys[k] = points.y[members[k]];
  }
  if (n == 0)
  {
    return {};
  }

  // The object's cluster: the most cells near the bottom edge, its nearest cell at the edge.
  const std::vector<std::size_t> label = clusterPoints(xs, ys, cluster_distance);
  const BottomEdge edge(box);
  std::map<std::size_t, ClusterTally> tallies;  // cluster label → its tally
  const double near2 = cluster_distance * cluster_distance;
  for (std::size_t k = 0; k < n; ++k)
  {
    const Eigen::Vector2d cell(xs[k], ys[k]);
    tallies[label[k]].add(
        points.v[members[k]], edge,
        std::any_of(expected.begin(), expected.end(),
                    [&](const Eigen::Vector2d& e) { return (e - cell).squaredNorm() <= near2; }));
  }
  std::size_t chosen = tallies.begin()->first;
  ClusterScore best = tallies.begin()->second.score(edge);
  for (const auto& [l, tally] : tallies)
  {
    const ClusterScore score = tally.score(edge);
    if (score.beats(best))
    {
      chosen = l;
      best = score;
    }
  }
  std::vector<std::uint32_t> cluster;
  for (std::size_t k = 0; k < n; ++k)
  {
    if (label[k] == chosen)
    {
      cluster.push_back(members[k]);
    }
  }
  return cluster;
}

CentreEstimate estimateCentre(const ProjectedPointsView& points, const std::vector<std::uint32_t>& members,
                              const BoundingBox& box, double camera_x, double camera_y,
                              const Footprint* footprint, const CentreConfig& config)
{
  if (members.empty())
  {
    throw std::invalid_argument("estimateCentre: no points");
  }
  return centreOfCluster(points, objectCluster(points, members, box, config.cluster_distance), camera_x,
                         camera_y, footprint, config.max_scans_since_hit);
}

CentreEstimate centreOfCluster(const ProjectedPointsView& points, const std::vector<std::uint32_t>& cluster,
                               double camera_x, double camera_y, const Footprint* footprint,
                               int max_scans_since_hit)
{
  if (cluster.empty())
  {
    throw std::invalid_argument("centreOfCluster: no points");
  }
  std::vector<double> cx, cy, fresh_x, fresh_y;
  for (std::uint32_t i : cluster)
  {
    cx.push_back(points.x[i]);
    cy.push_back(points.y[i]);
    if (max_scans_since_hit >= 0 && points.scans_since_hit &&
        points.scans_since_hit[i] <= max_scans_since_hit)
    {
      fresh_x.push_back(points.x[i]);
      fresh_y.push_back(points.y[i]);
    }
  }
  bool covers_more = false;
  const CentreEstimate all = centreOfCells(cx, cy, camera_x, camera_y, footprint, covers_more);
  if (!covers_more || fresh_x.size() < kMinFreshCentreCells || fresh_x.size() == cx.size())
  {
    return all;
  }
  return centreOfCells(fresh_x, fresh_y, camera_x, camera_y, footprint, covers_more);
}

}  // namespace grid_vision_fusion
