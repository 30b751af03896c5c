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
// The grid speaks about the same object through its own filter, which already integrates over
// time: its evidence enters the published probability once, at the image, instead of being
// accumulated image after image (which would count the same grid belief again and again):
//   - the dynamic share r̄ of the object's cells (mean of P(D) / (P(S) + P(D))), read as a vote
//     that errs with probability grid_error: L(D) : L(S) = (ε + (1 − 2ε) r̄) : (1 − ε − (1 − 2ε) r̄);
//   - the cells' velocity ĝ with the spread of their particles Σ (the Mahalanobis test of Nuss et
//     al., IJRR 2018, as a likelihood): t(ĝ; 0, Σ) under S, t(ĝ; v_D, Σ + P_v) under D, with D's
//     velocity v_D and covariance P_v as predicted before this image; ĝ then updates v_D (noise
//     Σ / r̄), so that a mover's particles start its velocity before its centres can.
// The object's lidar hits speak once per image too: their registration against the track's hits
// of a few scans before (scan_registration.h) gives a likelihood ratio of D against S that no
// drift of the centre estimate enters. The hits are the grid's cells, and their vote errs like
// the grid's: with probability grid_error (a cluster that holds another object's cells, a shape
// that changes), so that one registration moves the odds by at most (1 − ε) / ε.
// P(dynamic) = μ_D · L_D / (μ_D · L_D + μ_S · L_S), L the likelihoods of the grid and the hits.
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
  /// Mixes the two models for a step of `dt` [s] (the mode may switch) and predicts both; dt <= 0
  /// leaves the filter unchanged.
  void predict(double dt);
  /// Updates both models with the observed centre `position` [m] and the mode probability with
  /// their likelihoods.
  void update(const Eigen::Vector2d& position);
  /// The same with a centre whose noise covariance grows by `extra_noise` [m²] (a box cut by the
  /// image edge: its centre is off along the object's length by up to the length it hides).
  void update(const Eigen::Vector2d& position, const Eigen::Matrix2d& extra_noise);

  /// Takes in what the grid says about the object at this image: its likelihood ratio of D
  /// against S (from the velocity the constant-velocity model predicted, before this image's
  /// grid velocity), which pDynamic() applies, then the constant-velocity model's velocity is
  /// updated with the grid's (noise: its spread over the dynamic share). The mode probability
  /// itself does not change: the grid's own filter integrates over time already.
  void updateGrid(const GridMotionEvidence& grid);
  /// Takes in the registration of the object's lidar hits in an earlier scan `dt` [s] ago and in
  /// this image's (scan_registration.h): its likelihood ratio of D against S, from the velocity the
  /// constant-velocity model has now, as a vote that errs with probability grid_error, which
  /// pDynamic() applies. Like the grid's, this evidence is not accumulated (the registrations of
  /// consecutive images share scans).
  /// The hits are in metres on the grid's lattice of step `cell_size` [m]; `unseen` [m²] is the
  /// displacement they cannot show (registrationLogRatio()); no evidence without enough hits in
  /// either scan, a lattice, or dt > 0.
  void updateRegistration(const std::vector<Eigen::Vector2d>& then, const std::vector<Eigen::Vector2d>& now,
                          double cell_size, double dt,
                          const Eigen::Matrix2d& unseen = Eigen::Matrix2d::Zero());

  /// P(dynamic) of the centres alone (the filter's mode probability).
  double modeProbability() const { return mu_dynamic_; }
  /// P(dynamic) with the grid's evidence and the hits' registration of the latest updateGrid()
  /// and updateRegistration() since the last predict().
  double pDynamic() const;

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

  MotionModelConfig config_;
  Eigen::Vector2d standing_ = Eigen::Vector2d::Zero();  ///< S: position
  Eigen::Matrix2d standing_cov_ = Eigen::Matrix2d::Identity();
  Eigen::Vector4d moving_ = Eigen::Vector4d::Zero();  ///< D: position, velocity
  Eigen::Matrix4d moving_cov_ = Eigen::Matrix4d::Identity();
  double mu_dynamic_ = 0.5;
  double grid_log_ratio_ = 0.0;          ///< log L(D) − log L(S) of the grid at the latest image
  double registration_log_ratio_ = 0.0;  ///< the same of the hits' registration
};

/// Log-density of a bivariate Student-t with ν = 1 (Cauchy) and scale matrix `scale` at
/// `residual`.
double logCauchy2(const Eigen::Vector2d& residual, const Eigen::Matrix2d& scale);

}  // namespace grid_vision_fusion
