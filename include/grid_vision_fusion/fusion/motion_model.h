// The motion model of a track: is the object standing or moving? One model, with a probability.
//
// An interacting multiple model filter (Blom & Bar-Shalom 1988) of two motion models over the
// object's observed centre in the fixed (grid) frame:
//   S  stationary: the position does not change;
//   D  constant velocity with white acceleration noise.
// The mode m ∈ {S, D} is a Markov chain that switches with probability 1 − exp(−Δt / switch_time)
// between two images. Each model's Kalman filter predicts the centre; the likelihood of the
// observed centre under each gives the posterior mode probability μ_D = P(D | centres). Where the
// filter switches from S to D, the velocity starts from the prior N(0, speed_sigma² I): the
// Occam factor that lets "standing" win over "moving at about zero" (an IMM that mixes the
// stationary model's zero velocity into D could never tell the two apart).
//
// The observed centre is heavy-tailed (it jumps when the visible part of the object changes): its
// likelihood is a bivariate Student-t with ν = 1 (Cauchy) of scale position_sigma — the frame-to-
// frame steps of the centres of standing objects fit ν = 1 best (doc/nodelets/fusion.md).
//
// Each image's evidence beyond the centre enters the published probability once, at that image,
// instead of being accumulated image after image: the grid's own filter integrates over time
// already, and the registrations of consecutive images share scans. The tracker holds it per
// image (MotionEvidence); the filter's mode probability μ_D holds the centres' alone:
//   - the grid: the dynamic share r̄ of the object's cells (mean of P(D) / (P(S) + P(D))), read as
//     a vote that errs with probability grid_error: L(D) : L(S) = (ε + (1 − 2ε) r̄) : (1 − ε −
//     (1 − 2ε) r̄); and the cells' velocity ĝ with the spread of their particles Σ (the
//     Mahalanobis test of Nuss et al., IJRR 2018, as a likelihood): t(ĝ; 0, Σ) under S,
//     t(ĝ; v_D, Σ + P_v) under D, with D's velocity v_D and covariance P_v after this image's
//     centre and before ĝ; ĝ then updates v_D (noise Σ / r̄), so that a mover's particles start
//     its velocity before its centres can (updateGrid());
//   - the hits: their registration against the track's hits of a few scans before
//     (scan_registration.h) gives a likelihood ratio of D against S that no drift of the centre
//     estimate enters. The hits are the grid's cells, and their vote errs like the grid's: with
//     probability grid_error (a cluster that holds another object's cells, a shape that changes),
//     so that one registration moves the odds by at most (1 − ε) / ε (registrationEvidence()).
// P(dynamic) = μ_D · L_D / (μ_D · L_D + μ_S · L_S), L the likelihoods of the grid and the hits
// (pDynamic()). The constants the model does not expose as parameters are in model_constants.h.
#pragma once

#include "grid_vision_fusion/fusion/scan_registration.h"

#include <Eigen/Core>

#include <vector>

namespace grid_vision_fusion
{
/// Parameters of the motion model. Each has a physical meaning; together they are the whole
/// motion verdict.
struct MotionModelConfig
{
  /// Scale of the noise of the observed centre [m], > 0 (Student-t, ν = 1). About the spread of
  /// the centre of a standing object from image to image: less than a grid cell.
  double position_sigma = 0.15;
  /// White acceleration of the constant-velocity model [m/s²], > 0.
  double acceleration_sigma = 2.0;
  /// Prior velocity of an object that starts to move or is first seen, per axis [m/s], > 0.
  double speed_sigma = 3.0;
  /// Mean time between two changes of the motion mode [s], > 0: the inertia of the verdict.
  double switch_time = 2.0;
  /// Probability that a vote of the grid points the wrong way, (0, 0.5): the dynamic share of an
  /// object's cells, and the registration of its hit cells.
  double grid_error = 0.05;

  /// @throws std::invalid_argument naming the first bad field (as the ranges above).
  void validate() const;
};

/// What the dynamic grid says about one object's motion, from its cells.
struct GridMotionEvidence
{
  /// Mean dynamic share P(D) / (P(S) + P(D)) of the object's cells, [0, 1]; 0.5 says nothing.
  double dynamic_share = 0.5;
  /// The cells' velocity: their velocities weighted by their dynamic share [m/s], fixed frame...
  Eigen::Vector2d velocity = Eigen::Vector2d::Zero();
  /// ...and its variance per axis [m²/s²]: the spread of the particles and of the cells' means.
  Eigen::Vector2d velocity_variance = Eigen::Vector2d::Zero();
  /// Whether velocity and velocity_variance are given (the grid carried its variances).
  bool has_velocity = false;
};

/// What one image says about an object's motion besides its centre: log-likelihood ratios of D
/// against S. It counts for that image only.
struct MotionEvidence
{
  double grid = 0.0;          ///< of the grid's cells (MotionModel::updateGrid())
  double registration = 0.0;  ///< of the registration of its hits (MotionModel::registrationEvidence())
};

/// The interacting multiple model of one track. Copyable value type; not thread-safe.
class MotionModel
{
public:
  /// @throws std::invalid_argument when `config` is invalid.
  explicit MotionModel(const MotionModelConfig& config = MotionModelConfig());

  /// Starts the filters at `position` [m] with no velocity, the prior's uncertainty on it; the
  /// mode probability becomes `p_dynamic` ([0, 1]), e.g. 0.5 for a new object.
  void start(const Eigen::Vector2d& position, double p_dynamic);
  /// A jump of the centre estimate to `position` [m] (the visible part of the object changed, or
  /// its cells took another object's), which says nothing about the motion: the mode probability
  /// stays. The constant-velocity model moves to `position` with the measurement's uncertainty
  /// and keeps its velocity, whose uncertainty goes back to the prior's: it was measured on the
  /// centres before the jump, which may have followed another part of the object or another
  /// object's cells. The stationary model takes its estimate before the jump and `position` as
  /// equally likely: it moves halfway, and its covariance spans both.
  void restartAt(const Eigen::Vector2d& position);
  /// A step of `dt` [s]: mix() for the chance that the mode switched, then predictModels(); dt <= 0
  /// leaves the filter unchanged.
  void predict(double dt);
  /// Updates both models with the observed centre `position` [m] and the mode probability with
  /// their likelihoods.
  void update(const Eigen::Vector2d& position);
  /// The same with a centre whose noise covariance grows by `extra_noise` [m²] (a box cut by the
  /// image edge: its centre is off along the object's length by up to the length it hides).
  void update(const Eigen::Vector2d& position, const Eigen::Matrix2d& extra_noise);

  /// Takes in what the grid says about the object at this image and returns its log-likelihood
  /// ratio of D against S (MotionEvidence::grid). The ratio is judged against the velocity the
  /// constant-velocity model has before the grid's velocity enters (after this image's centre, when
  /// update() came first), then that velocity is updated with the grid's (noise: its spread over
  /// the dynamic share). The mode probability itself does not change: the grid's own filter
  /// integrates over time already.
  [[nodiscard]] double updateGrid(const GridMotionEvidence& grid);
  /// The log-likelihood ratio of D against S (MotionEvidence::registration) of the registration of
  /// the object's lidar hits in an earlier scan `dt` [s] ago and in this image's
  /// (scan_registration.h), from the velocity the constant-velocity model has now, as a vote that
  /// errs with probability grid_error. The hits are in metres on the grid's lattice of step
  /// `cell_size` [m]; `unseen` [m²] is the displacement they cannot show
  /// (registrationLogRatio()); 0 without enough hits in either scan, a lattice, or dt > 0.
  double registrationEvidence(const std::vector<Eigen::Vector2d>& then,
                              const std::vector<Eigen::Vector2d>& now, double cell_size, double dt,
                              const Eigen::Matrix2d& unseen = Eigen::Matrix2d::Zero()) const;

  /// P(dynamic) of the centres alone (the filter's mode probability).
  double modeProbability() const { return mu_dynamic_; }
  /// P(dynamic) with an image's evidence besides the centres.
  double pDynamic(const MotionEvidence& evidence) const;

  /// The combined estimate (x, y, vx, vy) [m, m/s]: the models' means weighted by their
  /// probabilities (the stationary model's velocity is zero), and its covariance.
  Eigen::Vector4d state() const;
  Eigen::Matrix4d covariance() const;
  /// The constant-velocity model's velocity [m/s]: the object's velocity should it move.
  Eigen::Vector2d movingVelocity() const { return moving_.tail<2>(); }
  /// ...and its covariance [m²/s²].
  Eigen::Matrix2d movingVelocityCovariance() const { return moving_cov_.bottomRightCorner<2, 2>(); }
  /// Squared Mahalanobis distance of `position` from the combined predicted centre, with the
  /// measurement noise covariance `noise` [m²] (the tracker's association gate).
  double distance2(const Eigen::Vector2d& position, const Eigen::Matrix2d& noise) const;

  /// Replaces the configuration, keeping the state. @throws std::invalid_argument when invalid.
  void setConfig(const MotionModelConfig& config);
  const MotionModelConfig& config() const { return config_; }

private:
  /// The noise covariance of an observed centre [m²]: motion_position_sigma² on each axis.
  Eigen::Matrix2d positionNoise() const;
  /// The constant-velocity model at `position` with the measurement's uncertainty, its velocity
  /// kept with the prior's uncertainty.
  void restartMoving(const Eigen::Vector2d& position);
  /// IMM step 1: each model restarts from the mixture of both, weighted by the probability that
  /// the mode was that model's given that it is this one's after a switch with probability
  /// `p_switch`; the mode probability becomes the predicted one.
  void mix(double p_switch);
  /// IMM step 2: the stationary model stands, the constant-velocity model moves for `dt` [s].
  void predictModels(double dt);

  MotionModelConfig config_;
  Eigen::Vector2d standing_ = Eigen::Vector2d::Zero();  ///< S: position
  Eigen::Matrix2d standing_cov_ = Eigen::Matrix2d::Identity();
  Eigen::Vector4d moving_ = Eigen::Vector4d::Zero();  ///< D: position, velocity
  Eigen::Matrix4d moving_cov_ = Eigen::Matrix4d::Identity();
  double mu_dynamic_ = 0.5;
};

/// Log-density of a bivariate Student-t with ν = 1 (Cauchy) and scale matrix `scale` at
/// `residual`.
double logCauchy2(const Eigen::Vector2d& residual, const Eigen::Matrix2d& scale);

}  // namespace grid_vision_fusion
