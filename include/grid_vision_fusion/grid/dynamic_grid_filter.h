// CMCDOT-style dynamic occupancy grid: four analytic states per cell (static, dynamic, empty,
// unknown), the velocity of the dynamic part carried by particles (conditional Monte Carlo).
// This is a documented reconstruction of CMCDOT (Rummelhard et al. 2015); every equation, with its
// parameters and their defaults, is in doc/grid_filter.md.
#pragma once

#include <Eigen/Geometry>

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "grid_vision_fusion/grid/grid_array.h"
#include "grid_vision_fusion/grid/grid_map.h"
#include "grid_vision_fusion/grid/inverse_sensor_model.h"
#include "grid_vision_fusion/grid/parallel_blocks.h"

namespace grid_vision_fusion
{
/// Parameters of the filter. Defaults: KITTI (HDL-64E at 10 Hz).
struct DynamicGridConfig
{
  // --- grid ---
  int width = 300;          ///< cells along x [cells] (8..4000)
  int height = 300;         ///< cells along y [cells] (8..4000)
  double resolution = 0.2;  ///< cell edge [m] (0.01..5)
  double lookahead = 15.0;  ///< grid centre this far ahead of the sensor along its heading [m]

  // --- time ---
  double max_time_gap = 1.0;       ///< a larger gap between scans received resets the grid [s] (>0)
  double transition_period = 0.1;  ///< period the eps_* probabilities refer to [s] (>0)

  // --- transitions: probability of leaving state X for Y within transition_period ---
  double eps_static_to_dynamic = 0.005;
  double eps_static_to_unknown = 0.05;
  double eps_dynamic_to_static = 0.01;
  double eps_dynamic_to_unknown = 0.05;
  double eps_free_to_static = 0.005;
  double eps_free_to_dynamic = 0.02;
  double eps_free_to_unknown = 0.05;
  // U -> X act only through an observation (scaled by its information, see doc/grid_filter.md):
  // the probability that one observation resolves an unknown cell into S, D or E.
  double eps_unknown_to_static = 0.3;
  double eps_unknown_to_dynamic = 0.3;
  double eps_unknown_to_free = 0.3;

  // --- particles ---
  int particle_count = 1 << 17;       ///< particles carrying the dynamic mass (16..2^24)
  double birth_fraction = 0.1;        ///< newborn particles per cycle / particle_count (0..1]
  double birth_velocity_sigma = 6.0;  ///< std-dev of a newborn particle's velocity per axis [m/s] (>0)
  double acceleration_sigma = 2.0;    ///< process noise, std-dev of the acceleration per axis [m/s^2] (>=0)
  double max_speed = 50.0;            ///< particles faster than this are dropped [m/s] (>0)
  /// Motion-driven birth: newborn particles of a cell that appears occupied (measured occupied
  /// now, not in the previous scan) take, with probability birth_motion_fraction, the velocity
  /// of the displacement from a cell vacated within the same interval (measured occupied before,
  /// free now) at most birth_motion_speed * dt away [m/s] (>=0; 0 disables).
  double birth_motion_speed = 20.0;
  double birth_motion_fraction = 0.5;  ///< share of such newborn particles [0, 1]
  /// Seed of the random streams (same seed + input = same output, whatever `threads`).
  std::uint32_t seed = 42;
  /// Threads of the sensor model and the filter passes (0 = all cores, 1 = serial); the output
  /// does not depend on it (doc/grid_filter.md, "Determinism") (0..256).
  int threads = 0;

  // --- motion evidence (doc/grid_filter.md, "Motion evidence"). The previous reconstruction is
  // vacated_to_dynamic = false, motion_window = 0, unknown_to_dynamic_by_motion,
  // static_to_dynamic_by_motion and propagation_rate = 0, inherit_birth_velocity = false (and
  // sensor_model.hit_neighbours_not_free = false). ---
  /// Dynamic mass that left an observed cell with its particles becomes newborn dynamic mass in
  /// proportion q = D / (S + D) (1 - exp(-m^2 / 2)): the dynamic share of the cell's occupied
  /// mass times the significance m^2 = vx^2/var_x + vy^2/var_y of the velocity that left (the
  /// next part of a moving object takes its place); the rest of the observed part is explained by
  /// the measurement alone. False: all of it becomes unknown.
  bool vacated_to_dynamic = true;
  /// A cell is *vacated* when it held obstacle points within this window, is seen clearly free
  /// (p_o <= 1/4) now and was believed occupied (P(S) + P(D) >= 0.6); it *appeared* when it
  /// holds obstacle points now, was seen clearly free within the window and was believed free
  /// (P(E) >= 0.6) [s] (>= 0; whole transition periods, rounded up; 0: the previous scan only,
  /// with the looser tests p_o > 1/2 then p_o < 1/2, and no motion evidence).
  double motion_window = 0.3;
  /// A cell has motion evidence when it appeared, or lies within this distance of a vacated cell
  /// [m] (>= 0). Vacated and appeared cells count only with a vacated (appeared) neighbour.
  double motion_radius = 0.6;
  /// The motion evidence of a cell decays as exp(-dt / motion_memory) [s] (> 0): slow objects
  /// (less than a cell per scan) accumulate it over several scans.
  double motion_memory = 0.45;
  /// Share of the unknown-to-static transition that goes to dynamic instead in a cell with full
  /// motion evidence [0, 1] (0: U -> S/D as eps_unknown_to_static/dynamic everywhere).
  double unknown_to_dynamic_by_motion = 1.0;
  /// Probability that the static mass of a cell measured occupied becomes dynamic within
  /// transition_period at full motion evidence (a static object that starts) [0, 1).
  double static_to_dynamic_by_motion = 0.1;
  /// Newborn particles of a cell with motion evidence and persistent particles take the cell's
  /// velocity estimate (mean, variance) instead of a random velocity.
  bool inherit_birth_velocity = true;
  /// Rigid-object prior: a cell measured occupied with P(D) >= 1/2, a significant velocity
  /// (m^2 >= 9) and motion evidence turns this share of the static mass of the occupied cells on
  /// its velocity line (both ways, up to propagation_length, across gaps of one cell) into
  /// dynamic mass with its velocity, per transition_period [0, 1) (0 disables).
  double propagation_rate = 0.3;
  double propagation_length = 12.0;  ///< [m] (> 0)

  // --- classification (reporting only, the filter does not use it) ---
  double dynamic_threshold = 0.5;      ///< P(D) from which a cell may be dynamic (0..1]
  double min_dynamic_speed = 1.0;      ///< mean speed from which a cell may be dynamic [m/s] (>=0)
  double mahalanobis_threshold = 4.0;  ///< v^T Sigma^-1 v from which a cell may be dynamic (>=0)
  double occupied_threshold = 0.5;     ///< P(S) + P(D) from which a cell is occupied (0..1]

  InverseSensorModelConfig sensor_model;

  /// @throws std::invalid_argument naming the first field out of its range (sensor_model too).
  void validate() const;
};

/// What one cycle did.
struct DynamicGridCycle
{
  bool reset = false;                ///< the grid was reset before this scan (time jump or gap)
  std::string reset_reason;          ///< why, for the caller's warning; empty when reset is false
  double dt = 0.0;                   ///< time since the previous scan [s] (0 on the first one)
  std::int64_t shift_cols = 0;       ///< grid moved by this many cells along x
  std::int64_t shift_rows = 0;       ///< grid moved by this many cells along y
  std::size_t particles_in_use = 0;  ///< particles with a non-zero weight after resampling
  std::size_t particles_born = 0;
  InverseSensorModelStats sensor;     ///< counters of the inverse sensor model
  double sensor_model_seconds = 0.0;  ///< wall time of the inverse sensor model [s]
  double filter_seconds = 0.0;        ///< wall time of everything else in the cycle [s]
};

/// Motion class of a cell for reporting (grid/cells, occupancy).
enum class CellClass : std::uint8_t
{
  kUnknown = 0,
  kFree = 1,
  kStatic = 2,
  kDynamic = 3,
};

/// Particles as a structure of arrays; positions relative to the corner of grid cell (0,0).
struct ParticleArrays
{
  GridArray<float> x;            ///< [m] from the grid origin along +x
  GridArray<float> y;            ///< [m] from the grid origin along +y
  GridArray<float> vx;           ///< [m/s]
  GridArray<float> vy;           ///< [m/s]
  GridArray<float> weight;       ///< absolute dynamic mass; the sum over a cell is its persistent P(D)
  GridArray<std::int32_t> cell;  ///< row-major cell index, -1 when outside the grid

  void resize(std::size_t n);
  std::size_t size() const { return weight.size(); }
};

/// The dynamic occupancy grid filter. Not thread-safe (one caller at a time); its passes run on
/// config.threads threads, and its output is bit-identical for a given seed and input sequence
/// whatever the thread count.
class DynamicGridFilter
{
public:
  /// @throws std::invalid_argument when `config` is invalid.
  explicit DynamicGridFilter(const DynamicGridConfig& config);

  /// One filter cycle for the scan `cloud` (sensor frame) taken at `stamp` [s] with the
  /// sensor at `world_from_sensor` (fixed frame <- sensor): grid shift, inverse sensor model,
  /// prediction, Bayes update, persistent/newborn split, velocity statistics, birth,
  /// resampling. An empty cloud gives a prediction step only. A stamp before the previous one,
  /// or more than max_time_gap after the last scan received (filtered, or skipped: skipScan()),
  /// resets the grid first (reported in the result).
  DynamicGridCycle update(const PointCloudView& cloud, const Eigen::Isometry3d& world_from_sensor,
                          double stamp);

  /// A scan taken at `stamp` arrived but is not filtered: the stage was busy and a newer scan
  /// replaced it (overload). The gap rule of update() then measures from this scan, so the next
  /// update() predicts over the longer interval instead of taking the stage's own drops for a
  /// sensor outage and resetting. Before the first update() it does nothing.
  void skipScan(double stamp);

  /// Forgets everything: all cells unknown, no particle, the random streams restarted.
  void reset();

  const DynamicGridConfig& config() const { return config_; }
  const GridGeometry& geometry() const { return geometry_; }
  const CellStates& cells() const { return cells_; }
  const ParticleArrays& particles() const { return particles_; }
  /// p_o of the last scan per cell (0.5 = no information).
  const std::vector<float>& measuredOccupancy() const { return occupancy_; }
  /// Scans since cell `index` last held obstacle points: 0 for the last scan, 255 for never (or
  /// 255 scans and more). Cells keep their occupancy where the sensor does not see them (behind
  /// other objects); this tells how fresh it is.
  std::uint8_t scansSinceHit(std::size_t index) const
  {
    return static_cast<std::uint8_t>(ages_[index] & 0xFF);
  }
  /// Ground height below the sensor of the last scan, fixed frame z [m].
  double groundZ() const { return ground_z_; }
  /// The ground under every cell as the last scan shows it, fixed frame z [m], row-major like
  /// cells(): the inverse sensor model's ground along the cell's polar sector at its range, or,
  /// from the sector's nearest obstacle on, just before that obstacle (where it stands, and where
  /// the scan does not reach the ground behind it; InverseSensorModel::groundHeightAt()). NaN
  /// beyond the model's max_range and before the first scan. Resizes `z` to the cell count.
  void cellGroundHeights(std::vector<float>& z) const;
  bool initialised() const { return initialised_; }
  double lastStamp() const { return last_stamp_; }

  /// Motion evidence per cell in [0, 1] after the last cycle (see DynamicGridConfig::motion_window).
  const GridArray<float>& motionEvidence() const { return motion_evidence_; }

  /// Replaces the classification thresholds (dynamic_threshold, min_dynamic_speed,
  /// mahalanobis_threshold, occupied_threshold) by those of `thresholds`; they only affect
  /// reporting, so this is safe between cycles. @throws std::invalid_argument as validate().
  void setClassification(const DynamicGridConfig& thresholds);

  /// Reporting class of cell `index` (see DynamicGridConfig, classification).
  CellClass classify(std::size_t index) const;

private:
  /// A systematic sampling of the birth and of the resampling (defined with them).
  struct SystematicSamples;

  void placeGrid(const Eigen::Isometry3d& world_from_sensor, std::int64_t& col, std::int64_t& row) const;
  /// f(block, first_row, end_row) for the blocks of grid rows, in parallel (parallel_).
  template <typename F>
  void forRowBlocks(const F& f) const;
  /// Resets the filter (and says why in `cycle`) when `stamp` lies before the last scan's or more
  /// than max_time_gap after the last scan received.
  void resetAfterTimeJump(double stamp, DynamicGridCycle& cycle);
  /// Step 1, ego motion: places the grid for the sensor pose; after the first scan, moves the
  /// cells, the scan memory and the particles by the shift (reported in `cycle`).
  void moveGrid(const Eigen::Isometry3d& world_from_sensor, bool first, DynamicGridCycle& cycle);
  /// The previous scan's occupied mask, the ages and the motion evidence moved with the grid.
  void shiftScanMemory(std::int64_t shift_cols, std::int64_t shift_rows);
  /// The particles moved with the grid, so that they keep their fixed-frame position.
  void shiftParticles(std::int64_t shift_cols, std::int64_t shift_rows);
  /// Zeroes the masses the particles carry into the cells (step 3).
  void clearPredictedMasses();
  void predictParticles(float dt, float keep, float to_static, float to_unknown);
  /// Steps 4-5 per cell: predicted masses (eq. 5), Bayes update (eq. 6), persistent/newborn split
  /// (eq. 7), the newborn mass by origin; the sums of step 7 zeroed.
  void updateCells(double dt_transition);
  /// The newborn dynamic mass that the mass `hole`, moved out of cell `c` (static mass `s`,
  /// measurement information `lambda`) with its particles, becomes (vacated_to_dynamic); the
  /// velocity that left kept for its particles.
  float vacatedToDynamic(std::size_t c, float s, float lambda, float hole);
  /// Step 6: persistent weights rescaled to the persistent posterior mass (eq. 8), summed per
  /// cell with their velocities for step 7.
  void accumulateVelocities(bool first);
  /// Step 7: velocity mean and variance given D per cell from the persistent particles (eq. 9).
  void estimateCellVelocities();
  /// Cuts the grid into one part of whole bands of kRowBlock rows per thread, with about as many
  /// particles each (part_band_). `counted`: block_counts_ already holds the particles per
  /// (particle block, band).
  void splitCellsByParticles(bool counted);
  /// f(i) for every particle i with a cell, one task per part of the grid (splitCellsByParticles)
  /// that goes through all particles in order and takes those in its cells: the per-cell sums f
  /// makes add each cell's particles in particle order, as one thread does, whatever the split.
  template <typename F>
  void forParticlesByCellPart(const F& f) const;
  /// Steps 8-9: birth in proportion to the newborn mass (`born` newborn particles), then
  /// resampling; returns the particles in use.
  std::size_t birthAndResample(std::size_t& born, float dt);
  /// Step 8 (eq. 10): the newborn particles, systematic samples of the cells' newborn mass from
  /// the offset `u_birth`; returns their count.
  std::size_t sampleBirths(float u_birth, float dt);
  /// The newborn particles of the cells of row block `b` (rows [r_begin, r_end)).
  void birthInRowBlock(std::size_t b, int r_begin, int r_end, const SystematicSamples& samples, float dt);
  /// Newborn particles [first, end) in cell `c`: position, weight and a velocity by origin.
  void bearParticles(std::size_t c, std::size_t first, std::size_t end, float dt, BlockRandom& rng,
                     std::vector<std::int32_t>& candidates);
  /// Step 9 (eq. 11): systematic resampling of the particles and the `born` newborn ones from the
  /// offset `u_resample`; returns the particles in use.
  std::size_t resample(float u_resample, std::size_t born);
  /// The resampled copies of the items of block `b` (resample()).
  void resampleBlock(std::size_t b, std::size_t particle_blocks, std::size_t born,
                     const SystematicSamples& samples);
  /// Appearing and vacated cells of this scan (from occupancy_ and the previous scan's mask).
  void findMotionCells(bool first, float dt);
  /// The vacated cells (vacated_), in increasing order: within the motion window (`windowed`,
  /// `window` scans) or against the previous scan's mask.
  void collectVacatedCells(bool windowed, int window);
  /// The vacated cells sorted by bucket of kBucket x kBucket cells (counting sort).
  void bucketVacatedCells();
  /// The vacated cells that have a vacated neighbour, marked in vacated_count_; whether there is
  /// any.
  bool markVacatedEdges();
  /// vacated_count_ into its summed-area table.
  void sumVacatedCounts();
  /// Motion evidence 1 within motion_radius of a vacated edge (when `any_vacated`), else the
  /// previous evidence decayed over `dt`.
  void spreadMotionEvidence(float dt, bool any_vacated);
  /// Motion evidence 1 in the cells that appeared (`window` scans, hit p_o >= `p_hit`) next to
  /// another that appeared.
  void markAppearedEdges(int window, float p_hit);
  /// Scans since each cell held obstacle points / was seen clearly free; this scan's occupied mask.
  void updateAges(bool evidence, float p_hit);
  /// Rigid-object prior (propagation_rate): static mass of occupied cells on the velocity line of
  /// a moving cell becomes newborn dynamic mass with that cell's velocity.
  void propagateMotion(float dt);
  /// Velocity of a newborn particle at (x, y) of cell `cell` from a random vacated cell within
  /// birth_motion_speed * dt; false when there is none. `candidates`: scratch.
  bool motionVelocity(std::size_t cell, float x, float y, float dt, float& vx, float& vy, BlockRandom& rng,
                      std::vector<std::int32_t>& candidates) const;

  DynamicGridConfig config_;
  ParallelBlocks parallel_;
  InverseSensorModel sensor_model_;
  GridGeometry geometry_;
  CellStates cells_;
  ParticleArrays particles_;
  ParticleArrays resampled_;
  std::vector<float> occupancy_;
  // per-cell scratch
  GridArray<float> pred_dynamic_;          // persistent predicted dynamic mass (particles)
  GridArray<float> from_dynamic_static_;   // D -> S mass arriving with particles
  GridArray<float> from_dynamic_unknown_;  // D -> U mass arriving with particles
  GridArray<float> newborn_;               // posterior newborn dynamic mass
  GridArray<float> persistent_factor_;
  // newborn mass by origin, as shares of the cell's newborn mass, and the velocity (mean,
  // variance per axis) their particles take
  GridArray<float> vacated_share_;     // vacated_to_dynamic: the velocity that left the cell
  GridArray<float> start_share_;       // static_to_dynamic_by_motion: motion-driven velocity
  GridArray<float> propagated_share_;  // propagation_rate: the source cell's velocity
  GridArray<float> left_vx_, left_vy_, left_var_x_, left_var_y_;
  GridArray<float> source_vx_, source_vy_, source_var_x_, source_var_y_, source_weight_;
  GridArray<float> stat_w_, stat_vx_, stat_vy_, stat_vxx_, stat_vyy_;
  // birth scratch
  GridArray<std::int32_t> birth_cell_;
  GridArray<float> birth_x_, birth_y_, birth_vx_, birth_vy_, birth_w_;
  // motion-driven birth
  GridArray<std::uint8_t> occupied_mask_;  // measured occupied (p_o > 1/2) in the last scan
  GridArray<std::uint8_t> previous_mask_;  // the same for the scan before, shifted with the grid
  // motion evidence: scans since the cell last held obstacle points (low byte) / was seen
  // clearly free (high byte), each saturating at 255, shifted with the grid; the evidence itself
  GridArray<std::uint16_t> ages_, age_scratch_;
  GridArray<float> motion_evidence_, evidence_scratch_;
  std::vector<std::int32_t> vacated_count_;  // summed-area table of the vacated cells
  std::vector<std::size_t> isolated_;        // scratch: vacated cells without a vacated neighbour
  std::vector<std::int32_t> vacated_;        // cells occupied in the previous scan, free now
  std::vector<std::int32_t> bucket_start_;   // vacated_ sorted by bucket: first index per bucket
  std::vector<std::int32_t> bucket_cells_;
  std::vector<std::int32_t> candidates_;  // scratch: bucket fill positions
  // block scratch: partial sums and their exclusive prefix (block order), per-block counts
  std::vector<double> block_sum_;
  std::vector<double> block_start_;
  std::vector<std::size_t> block_counts_;
  std::vector<std::size_t> band_particles_;  // particles per band of kRowBlock rows
  std::vector<std::size_t> part_band_;       // first band of each part of the grid, then the band count
  std::vector<std::vector<std::int32_t>> block_candidates_;  // per row block: vacated cells, candidates
  int bucket_cols_ = 0;
  int bucket_rows_ = 0;
  bool have_previous_ = false;
  std::uint64_t cycle_ = 0;  // cycles since the last reset: part of every random stream's seed
  bool initialised_ = false;
  double last_stamp_ = 0.0;           // the last scan filtered
  double last_received_stamp_ = 0.0;  // the last scan received: filtered or skipped
  double ground_z_ = 0.0;
  Eigen::Vector3d sensor_origin_ = Eigen::Vector3d::Zero();  ///< of the last scan, fixed frame [m]
};

}  // namespace grid_vision_fusion
