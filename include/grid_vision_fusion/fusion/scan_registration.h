// Scan registration of an object's lidar hits: how far did the object move between two scans?
//
// The centre of a partly seen object drifts with its visible part (a parked car revealed by a
// passing truck, a car whose cells take a passing cyclist's, a standing car seen from a turning
// ego), and a drifting centre reads as motion. The grid cells the lidar hit on the object in two
// scans tell the two apart: the cells of a standing object are hit again at the same place, a
// moving object's at a place shifted by its displacement, wherever its centre estimate lies.
//
// The hits of each scan lie on the grid's lattice. Every pair (a hit now, a hit then) votes for
// the lattice shift between them; a shift's votes are the hits of now that a hit of then, moved by
// that shift, explains: its overlap. The likelihood of a displacement t is taken as
// exp(overlap(t)) (one nat per hit explained) and marginalised over the displacements each motion
// mode predicts: t ~ N(0, Q) standing, t ~ N(v·Δt, Δt² P_v + Q) moving at the constant-velocity
// model's velocity v with covariance P_v, where Q = cell² / 6 · I is the lattice's quantisation of
// the two scans. Shapes that fit several shifts as well (the long side of a vehicle moving along
// itself) spread their likelihood over those shifts and say little; a shape that fits only one
// shift says much. A displacement the hits cannot show (along an object cut by the image edge,
// whose visible part is a window sliding along it) blurs both modes alike: only the displacement
// across it is weighed.
#pragma once

#include <Eigen/Core>

#include <cstddef>
#include <vector>

namespace grid_vision_fusion
{
/// The overlap of two scans' hits per lattice shift (in cells).
class ShiftVotes
{
public:
  /// Counts, for every lattice shift s, the hits of `now` that a hit of `then` moved by s
  /// explains; positions in metres (fixed frame), `cell_size` the lattice's step [m] (> 0).
  /// Shifts farther than `max_shift` [m] (at most kMaxWindow cells) on either axis are not
  /// counted. Nothing is counted for more than kMaxPairs pairs (a wall of thousands of cells in
  /// one box: no evidence, in bounded time), fewer than kMinHits hits in either scan (they say
  /// nothing of a shape) or a cell size that is not finite and > 0.
  ShiftVotes(const std::vector<Eigen::Vector2d>& then, const std::vector<Eigen::Vector2d>& now,
             double cell_size, double max_shift);

  /// Fewest hits in each scan for any vote.
  static constexpr std::size_t kMinHits = 3;
  /// Most pairs of hits counted: 400 hits per scan, more than a truck's outline at 5 m.
  static constexpr std::size_t kMaxPairs = 160000;
  /// Farthest shift counted [cells]: 20 m on the 0.2 m grid.
  static constexpr int kMaxWindow = 100;

  /// Overlap of the shift (dx, dy) [cells].
  int overlap(int dx, int dy) const;
  /// The largest overlap over all shifts (0 without any).
  int maxOverlap() const { return max_overlap_; }
  double cellSize() const { return cell_size_; }

  /// Calls f(dx, dy, overlap) for each shift with an overlap (dx, dy in cells).
  template <typename F>
  void forEach(F&& f) const
  {
    const int side = 2 * window_ + 1;
    for (const int index : shifts_)
    {
      f(index % side - window_, index / side - window_, counts_[static_cast<std::size_t>(index)]);
    }
  }

private:
  int window_ = 0;           ///< shifts counted: |dx|, |dy| <= window_ [cells]
  std::vector<int> counts_;  ///< overlap per shift, row-major over dy then dx
  std::vector<int> shifts_;  ///< the indices of counts_ with an overlap, in the order first seen
  int max_overlap_ = 0;
  double cell_size_ = 0.0;
};

/// Log-likelihood ratio of moving against standing from the registration of two scans' hits
/// `dt` [s] apart (see the file comment): `velocity` [m/s] and `velocity_cov` [m²/s²] are the
/// constant-velocity model's. `unseen` [m²] is a displacement the hits cannot show, added to
/// both modes' (along the length of an object cut by the image edge, whose visible part slides
/// along it). 0 (no evidence) when dt <= 0 or either scan has no hit.
double registrationLogRatio(const ShiftVotes& votes, double dt, const Eigen::Vector2d& velocity,
                            const Eigen::Matrix2d& velocity_cov,
                            const Eigen::Matrix2d& unseen = Eigen::Matrix2d::Zero());
/// How far registrationLogRatio() looks for the displacement of hits `dt` [s] apart [m]: five
/// standard deviations of either mode's displacement, and five cells (arguments as there).
double registrationReach(double cell_size, double dt, const Eigen::Vector2d& velocity,
                         const Eigen::Matrix2d& velocity_cov,
                         const Eigen::Matrix2d& unseen = Eigen::Matrix2d::Zero());
/// The same from the two scans' hits (ShiftVotes' arguments), counting the shifts within
/// registrationReach().
double registrationLogRatio(const std::vector<Eigen::Vector2d>& then, const std::vector<Eigen::Vector2d>& now,
                            double cell_size, double dt, const Eigen::Vector2d& velocity,
                            const Eigen::Matrix2d& velocity_cov,
                            const Eigen::Matrix2d& unseen = Eigen::Matrix2d::Zero());

}  // namespace grid_vision_fusion
