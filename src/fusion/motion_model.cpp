#include "grid_vision_fusion/fusion/motion_model.h"
#include "grid_vision_fusion/fusion/model_constants.h"

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>

namespace grid_vision_fusion
{
namespace
{
void requireRange(const char* name, double value, double low, double high)
{
  if (!std::isfinite(value) || !(value > low) || !(value < high))
  {
    std::ostringstream msg;
    msg << name << " must be a finite value in (" << low << ", " << high << "), got " << value;
    throw std::invalid_argument(msg.str());
  }
}

/// Log of exp(a) + exp(b) without overflow.
double logAdd(double a, double b)
{
  const double high = std::max(a, b);
  return high + std::log1p(std::exp(std::min(a, b) - high));
}

/// Log-likelihood ratio of D to S of a vote for D with weight `vote` in [0, 1] that errs with
/// probability `error`.
double voteLogRatio(double vote, double error)
{
  const double p = error + (1.0 - 2.0 * error) * vote;
  return std::log(p) - std::log(1.0 - p);
}

/// The log-likelihood ratio `ratio` of evidence that errs with probability `error`: its vote is
/// the probability of D it gives from even odds.
double errs(double ratio, double error)
{
  return voteLogRatio(1.0 / (1.0 + std::exp(-ratio)), error);
}

/// The probability of D from the log-likelihoods of the two modes and the prior P(D).
double posterior(double prior_dynamic, double log_l_static, double log_l_dynamic)
{
  const double log_s = std::log(std::max(1.0 - prior_dynamic, 1e-300)) + log_l_static;
  const double log_d = std::log(std::max(prior_dynamic, 1e-300)) + log_l_dynamic;
  return std::exp(log_d - logAdd(log_s, log_d));
}

/// The Kalman update of the state `x` with covariance `p` by a measurement of its components
/// [first, first + 2) (the measurement matrix picks them): `innovation` is the measurement minus
/// those components, `innovation_cov` its covariance (theirs plus the measurement noise).
template <int N>
void kalmanUpdate(Eigen::Matrix<double, N, 1>& x, Eigen::Matrix<double, N, N>& p, int first,
                  const Eigen::Vector2d& innovation, const Eigen::Matrix2d& innovation_cov)
{
  const Eigen::Matrix<double, N, 2> gain = p.template middleCols<2>(first) * innovation_cov.inverse();
  x += gain * innovation;
  p -= gain * p.template middleRows<2>(first);
  p = 0.5 * (p + p.transpose());
}
}  // namespace

void MotionModelConfig::validate() const
{
  const double inf = std::numeric_limits<double>::infinity();
  requireRange("motion_position_sigma", position_sigma, 0.0, inf);
  requireRange("track_acceleration_sigma", acceleration_sigma, 0.0, inf);
  requireRange("motion_speed_sigma", speed_sigma, 0.0, inf);
  requireRange("motion_switch_time", switch_time, 0.0, inf);
  requireRange("motion_grid_error", grid_error, 0.0, 0.5);
}

double logCauchy2(const Eigen::Vector2d& residual, const Eigen::Matrix2d& scale)
{
  // Bivariate Student-t, ν = 1: Γ(3/2) / (Γ(1/2) π |Σ|^½) · (1 + d²)^(−3/2).
  constexpr double kLogNormaliser = -1.8378770664093453;  // log(Γ(3/2) / (Γ(1/2) π)) = log(1 / 2π)
  const double d2 = residual.dot(scale.ldlt().solve(residual));
  return kLogNormaliser - 0.5 * std::log(scale.determinant()) - 1.5 * std::log1p(d2);
}

MotionModel::MotionModel(const MotionModelConfig& config) : config_(config)
{
  config_.validate();
}

void MotionModel::setConfig(const MotionModelConfig& config)
{
  config.validate();
  config_ = config;
}

void MotionModel::start(const Eigen::Vector2d& position, double p_dynamic)
{
  standing_ = position;
  standing_cov_ = positionNoise();
  moving_.tail<2>().setZero();
  restartMoving(position);
  mu_dynamic_ = std::clamp(p_dynamic, 0.0, 1.0);
}

void MotionModel::restartAt(const Eigen::Vector2d& position)
{
  // A standing object does not jump: either its estimate before the jump or this centre is off.
  // The standing model takes both as equally likely, as the mean and covariance of the two,
  // and the next centres tell which.
  const Eigen::Vector2d jump = position - standing_;
  standing_ += 0.5 * jump;
  standing_cov_ = 0.5 * (standing_cov_ + positionNoise()) + 0.25 * jump * jump.transpose();
  restartMoving(position);
}

Eigen::Matrix2d MotionModel::positionNoise() const
{
  return config_.position_sigma * config_.position_sigma * Eigen::Matrix2d::Identity();
}

void MotionModel::restartMoving(const Eigen::Vector2d& position)
{
  const double r = config_.position_sigma * config_.position_sigma;
  const double v = config_.speed_sigma * config_.speed_sigma;
  // On a restart the velocity was measured on the centres before the jump, which followed
  // another part of the object or another object's cells: its value stays the best guess, its
  // certainty goes back to the prior's.
  moving_.head<2>() = position;
  moving_cov_ = Eigen::Vector4d(r, r, v, v).asDiagonal();
}

void MotionModel::predict(double dt)
{
  if (!(dt > 0.0))
  {
    return;
  }
  mix(1.0 - std::exp(-dt / config_.switch_time));
  predictModels(dt);
}

void MotionModel::mix(double p_switch)
{
  // The probability that the mode was i given that it is j now, then each model's starting point
  // as the mixture of both. S enters D with the prior velocity.
  const double mu_s = 1.0 - mu_dynamic_;
  const double mu_d = mu_dynamic_;
  const double c_s = mu_s * (1.0 - p_switch) + mu_d * p_switch;
  const double c_d = mu_s * p_switch + mu_d * (1.0 - p_switch);
  const double w_ss = c_s > 0.0 ? mu_s * (1.0 - p_switch) / c_s : 1.0;  // S now, S before
  const double w_ds = 1.0 - w_ss;                                       // S now, D before
  const double w_sd = c_d > 0.0 ? mu_s * p_switch / c_d : 0.0;          // D now, S before
  const double w_dd = 1.0 - w_sd;                                       // D now, D before

  const double v_prior = config_.speed_sigma * config_.speed_sigma;
  Eigen::Vector4d from_standing;
  from_standing << standing_, 0.0, 0.0;
  Eigen::Matrix4d from_standing_cov = Eigen::Matrix4d::Zero();
  from_standing_cov.topLeftCorner<2, 2>() = standing_cov_;
  from_standing_cov.bottomRightCorner<2, 2>() = v_prior * Eigen::Matrix2d::Identity();

  const Eigen::Vector2d s0 = w_ss * standing_ + w_ds * moving_.head<2>();
  const Eigen::Vector2d ds = standing_ - s0;
  const Eigen::Vector2d dm = moving_.head<2>() - s0;
  const Eigen::Matrix2d s0_cov = w_ss * (standing_cov_ + ds * ds.transpose()) +
                                 w_ds * (moving_cov_.topLeftCorner<2, 2>() + dm * dm.transpose());
  const Eigen::Vector4d d0 = w_sd * from_standing + w_dd * moving_;
  const Eigen::Vector4d e_s = from_standing - d0;
  const Eigen::Vector4d e_d = moving_ - d0;
  const Eigen::Matrix4d d0_cov =
      w_sd * (from_standing_cov + e_s * e_s.transpose()) + w_dd * (moving_cov_ + e_d * e_d.transpose());
  standing_ = s0;
  standing_cov_ = s0_cov;
  moving_ = d0;
  moving_cov_ = d0_cov;
  mu_dynamic_ = c_d;
}

void MotionModel::predictModels(double dt)
{
  // S stands; D moves at constant velocity with white acceleration.
  Eigen::Matrix4d f = Eigen::Matrix4d::Identity();
  f(0, 2) = dt;
  f(1, 3) = dt;
  const double q = config_.acceleration_sigma * config_.acceleration_sigma;
  Eigen::Matrix4d noise = Eigen::Matrix4d::Zero();
  for (int axis = 0; axis < 2; ++axis)
  {
    noise(axis, axis) = q * dt * dt * dt * dt / 4.0;
    noise(axis, axis + 2) = noise(axis + 2, axis) = q * dt * dt * dt / 2.0;
    noise(axis + 2, axis + 2) = q * dt * dt;
  }
  moving_ = f * moving_;
  moving_cov_ = f * moving_cov_ * f.transpose() + noise;
}

void MotionModel::update(const Eigen::Vector2d& position)
{
  update(position, Eigen::Matrix2d::Zero());
}

void MotionModel::update(const Eigen::Vector2d& position, const Eigen::Matrix2d& extra_noise)
{
  const Eigen::Matrix2d r = positionNoise() + extra_noise;
  // The centre's likelihood under each model moves the mode probability (IMM step 3), then each
  // model's Kalman update.
  const Eigen::Vector2d nu_s = position - standing_;
  const Eigen::Matrix2d s_s = standing_cov_ + r;
  const Eigen::Vector2d nu_d = position - moving_.head<2>();
  const Eigen::Matrix2d s_d = moving_cov_.topLeftCorner<2, 2>() + r;
  mu_dynamic_ = posterior(mu_dynamic_, logCauchy2(nu_s, s_s), logCauchy2(nu_d, s_d));
  kalmanUpdate(standing_, standing_cov_, 0, nu_s, s_s);
  kalmanUpdate(moving_, moving_cov_, 0, nu_d, s_d);
}

double MotionModel::updateGrid(const GridMotionEvidence& grid)
{
  const double share = std::isfinite(grid.dynamic_share) ? std::clamp(grid.dynamic_share, 0.0, 1.0) : 0.5;
  double log_ratio = voteLogRatio(share, config_.grid_error);
  if (!grid.has_velocity || !grid.velocity.allFinite() || !grid.velocity_variance.allFinite())
  {
    return log_ratio;
  }
  const Eigen::Matrix2d spread = grid.velocity_variance.cwiseMax(kMinGridVariance).asDiagonal();
  const Eigen::Vector2d nu = grid.velocity - moving_.tail<2>();
  const Eigen::Matrix2d predicted = moving_cov_.bottomRightCorner<2, 2>();
  log_ratio += logCauchy2(nu, spread + predicted) - logCauchy2(grid.velocity, spread);
  // The cells' velocity as a measurement of the constant-velocity model's: the less of their
  // mass is dynamic, the less it says.
  const Eigen::Matrix2d noise = spread / std::max(share, kMinVelocityShare);
  kalmanUpdate(moving_, moving_cov_, 2, nu, predicted + noise);
  return log_ratio;
}

double MotionModel::registrationEvidence(const std::vector<Eigen::Vector2d>& then,
                                         const std::vector<Eigen::Vector2d>& now, double cell_size, double dt,
                                         const Eigen::Matrix2d& unseen) const
{
  const double ratio =
      registrationLogRatio(then, now, cell_size, dt, movingVelocity(), movingVelocityCovariance(), unseen);
  return errs(ratio, config_.grid_error);
}

double MotionModel::pDynamic(const MotionEvidence& evidence) const
{
  return posterior(mu_dynamic_, 0.0, evidence.grid + evidence.registration);
}

Eigen::Vector4d MotionModel::state() const
{
  Eigen::Vector4d standing;
  standing << standing_, 0.0, 0.0;
  return (1.0 - mu_dynamic_) * standing + mu_dynamic_ * moving_;
}

Eigen::Matrix4d MotionModel::covariance() const
{
  const Eigen::Vector4d mean = state();
  Eigen::Vector4d standing;
  standing << standing_, 0.0, 0.0;
  Eigen::Matrix4d standing_cov = Eigen::Matrix4d::Zero();
  standing_cov.topLeftCorner<2, 2>() = standing_cov_;
  const Eigen::Vector4d e_s = standing - mean;
  const Eigen::Vector4d e_d = moving_ - mean;
  return (1.0 - mu_dynamic_) * (standing_cov + e_s * e_s.transpose()) +
         mu_dynamic_ * (moving_cov_ + e_d * e_d.transpose());
}

double MotionModel::distance2(const Eigen::Vector2d& position, const Eigen::Matrix2d& noise) const
{
  const Eigen::Matrix2d s = covariance().topLeftCorner<2, 2>() + noise;
  const Eigen::Vector2d innovation = position - state().head<2>();
  return innovation.dot(s.ldlt().solve(innovation));
}

}  // namespace grid_vision_fusion
