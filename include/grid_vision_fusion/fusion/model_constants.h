// The fixed constants of the fusion's object model and of the tracks' motion model: the numbers
// that are not parameters. Each stands for a physical quantity, a unit of evidence or a numerical
// safeguard, was set once from what it stands for and is not tuned per drive; the parameters are
// FusionConfig, CentreConfig, TrackerConfig and MotionModelConfig (doc/nodelets/fusion.md).
#pragma once

namespace grid_vision_fusion
{
// --- Which cluster of a fusion band is the object (objectCluster()) ----------------------------

/// A cell counts fully up to this fraction of the box height below the bottom edge, then less
/// (Gaussian with this fraction as σ). A trained detector's bottom edge lies 3 % of the height
/// too high on average and errs by 3.5 % (σ, heavy-tailed; YOLOv5s on KITTI,
/// doc/detector_noise.md): at 5 % the object's own cells, seen below such an edge, lost to the
/// wall or kerb behind it (with the calibrated noise, 1.5 points of moving objects found dynamic
/// on the scenario suite).
constexpr double kBelowToleranceFraction = 0.1;
/// The same above the bottom edge: the object's ground cells project near its bottom edge, the
/// cells of what stands behind it higher.
constexpr double kAboveToleranceFraction = 0.1;
/// The root-mean-square error of a trained detector's bottom edge as a fraction of the box height:
/// its bias (0.032) and its spread (σ 0.035) together, YOLOv5s on KITTI (doc/detector_noise.md).
/// The nearest cell of the object's cluster projects onto the bottom edge up to this error.
constexpr double kBottomEdgeErrorFraction = 0.047;

// --- Boxes cut by the image edge (trackObjects()) ----------------------------------------------

/// A box edge this close to the image's left or right edge [px] cuts the object.
constexpr float kTruncationMarginPx = 1.F;
/// The same as a share of the image width, for a trained detector whose box edges stop a few
/// pixels short of the image's (YOLOv5s at 640 px on KITTI's 1242 px: up to 7 px, 0.6 %).
constexpr float kTruncationMargin = 0.01F;

// --- The grid's word on a track's motion (MotionModel::updateGrid()) ---------------------------

/// The smallest variance of the grid's velocity [m²/s²]: a cell whose particles all agree still
/// knows its velocity only to about 0.1 m/s.
constexpr double kMinGridVariance = 0.01;
/// The smallest dynamic share by which the grid's velocity noise is divided: cells with almost no
/// dynamic mass still say a little about the velocity.
constexpr double kMinVelocityShare = 0.05;

// --- The registration of a track's lidar hits (scan_registration.h, Tracker) -------------------

/// How far back the lidar hits of a track's objects are registered [s]: three scans at 10 Hz,
/// in which an object at 1 m/s moves 1.5 cells of 0.2 m (doc/nodelets/fusion.md, "Motion model").
/// Also how long the image edge sweeps along a cut object between the registered scans
/// (Tracker::cutNoise()).
constexpr double kRegistrationSpan = 0.3;
/// Slack on that span for stamps that jitter [s].
constexpr double kRegistrationSlack = 0.02;
/// The log-likelihood of a displacement per hit it explains [nat]: the likelihood of a shift is
/// exp(kNatsPerHit · overlap), one nat per hit.
constexpr double kNatsPerHit = 1.0;
/// How far the registration looks for a displacement: kReachSigmas standard deviations of the
/// moving model's displacement and of what the hits cannot show, where a shift weighs less than
/// exp(−kReachSigmas² / 2) of its mode's peak, ...
constexpr double kReachSigmas = 5.0;
/// ... plus this many lattice cells for the quantisation of the two scans.
constexpr double kReachCells = 5.0;
/// A mode's probability of a lattice shift is taken as 0 beyond this many standard deviations of
/// its displacement, where it is below exp(−kNegligibleSigmas² / 2) of the peak's.
constexpr double kNegligibleSigmas = 8.0;

}  // namespace grid_vision_fusion
