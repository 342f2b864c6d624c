// Batch smoothing of a finished run: the maximum-likelihood trajectory and map given every scan's
// odometry and every pairing the filter made (Gauss-Newton over all scan poses and all final
// landmarks at once; sparse Cholesky of the normal equations). ROS-free (Eigen only).
//
// Why: the EKF's map at the end of a run is the best it has, but each pose it wrote is the online
// estimate of that moment, before the loop closures that later moved the map; the smoother gives
// every scan the pose the whole run supports, in the same frame as its refined map. It keeps the
// filter's decisions (it re-estimates, it does not re-associate), so a wrong pairing stays wrong.
// docs/smoothing.md.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "ekf_slam/core/filter/ekf_slam.h"  // LandmarkId
#include "ekf_slam/core/filter/observation_model.h"

namespace ekf_slam {

/// One observation of a scan and the landmark the filter paired it with (or initialised from it).
struct SmoothingObservation {
  LandmarkId landmark = kNoLandmark;
  Eigen::Vector2d z = Eigen::Vector2d::Zero();
  Eigen::Matrix2d R = Eigen::Matrix2d::Identity();
  MeasurementKind kind = MeasurementKind::kRangeBearing;
  /// R is the pipeline's default (Observation::default_covariance): for noise calibration.
  bool default_covariance = false;
};

/// One scan: its pose as the filter estimated it (the starting point), the odometry since the
/// previous scan, and its pairings.
struct SmoothingScan {
  double stamp = 0.0;
  Eigen::Vector3d pose = Eigen::Vector3d::Zero();
  /// The filter's pose covariance at the scan: the prior of a scan without odometry from the one
  /// before (the first scan, after a reset), which anchors the map frame there.
  Eigen::Matrix3d pose_covariance = Eigen::Matrix3d::Identity();
  /// The odometry from the previous scan applies: `motion` in that scan's vehicle frame, with
  /// covariance `motion_covariance` (ScanReport::motion).
  bool linked = false;
  Eigen::Vector3d motion = Eigen::Vector3d::Zero();
  Eigen::Matrix3d motion_covariance = Eigen::Matrix3d::Zero();
  /// Its shares from the odometry's translation and rotation noise terms
  /// (ScanReport::motion_covariance_translation, _rotation): for noise calibration only.
  Eigen::Matrix3d motion_translation = Eigen::Matrix3d::Zero();
  Eigen::Matrix3d motion_rotation = Eigen::Matrix3d::Zero();
  std::vector<SmoothingObservation> observations;
};

struct SmoothingLandmark {
  LandmarkId id = kNoLandmark;
  Eigen::Vector2d position = Eigen::Vector2d::Zero();  ///< the filter's estimate
};

struct SmootherParams {
  int max_iterations = 20;
  /// Converged when an iteration lowers the cost by less than this fraction of it.
  double tolerance = 1e-6;
  /// Floor of a prior's or an odometry link's variances: a filter that knows its start exactly
  /// (zero initial sigma) or a standstill (zero motion noise) still gives a solvable system.
  double min_variance = 1e-10;
  /// The marginal 2x2 covariance (for a saved map) of the first this many input landmarks, the
  /// rest NaN; negative: of all. One solve per landmark coordinate with the final factorisation.
  int landmark_covariances = -1;
  /// SmoothingResult::residuals: every odometry and observation residual at the solution with
  /// its leverage J N^-1 J^T (the share of its covariance the fit absorbs), from the entries of
  /// N^-1 on the factor's pattern (Takahashi's equations). For noise calibration
  /// (noise_calibration.h).
  bool residuals = false;
};

/// One residual at the solution (SmootherParams::residuals).
struct SmoothingResidual {
  int scan = 0;
  /// Index in the scan's `observations`; -1: the odometry link from the previous scan.
  int observation = -1;
  /// z - h(x): the odometry's 3 rows, or an observation's first 2 (the rest 0).
  Eigen::Vector3d v = Eigen::Vector3d::Zero();
  /// J N^-1 J^T at the solution (same layout as v): the residual's covariance under the model is
  /// its noise covariance less this.
  Eigen::Matrix3d leverage = Eigen::Matrix3d::Zero();
};

struct SmoothingResult {
  bool ok = false;
  std::string error;                   ///< why not ok (e.g. the normal equations are singular)
  std::vector<Eigen::Vector3d> poses;  ///< one per input scan
  std::vector<SmoothingLandmark> landmarks;
  std::vector<Eigen::Matrix2d> landmark_covariances;  ///< one per input landmark (NaN: not asked)
  int iterations = 0;
  bool converged = false;
  /// Sum of squared Mahalanobis residuals (odometry, observations, priors) at the filter's
  /// estimates and at the solution; with `degrees_of_freedom` (residuals less unknowns), the
  /// solution's cost is a chi2 test of the whole model: far above its dof, the noise the filter
  /// assumed is too small or not white.
  double initial_cost = 0.0;
  double final_cost = 0.0;
  std::size_t degrees_of_freedom = 0;
  /// The solution's cost of each kind of residual per scalar residual (about 1 each when the
  /// noise the filter assumed fits the data; far below: that noise is inflated for this kind).
  double observation_cost_per_residual = 0.0;
  double odometry_cost_per_residual = 0.0;
  std::size_t observations = 0;          ///< observation residuals used
  std::size_t dropped_observations = 0;  ///< paired with landmarks not in the final map
  double seconds = 0.0;
  std::vector<SmoothingResidual> residuals;  ///< with SmootherParams::residuals
};

/// Smooths the run. Observations of landmarks not in `landmarks` (removed during the run) are
/// dropped. The first scan, and any scan not linked by odometry, is anchored at its filter pose
/// with its filter covariance.
SmoothingResult smoothRun(const std::vector<SmoothingScan>& scans,
                          const std::vector<SmoothingLandmark>& landmarks,
                          const RangeBearingModel& model,
                          const SmootherParams& params = SmootherParams());

/// The motion b - a expressed in a's frame, and its Jacobians w.r.t. a and b (3x3 each): the
/// prediction of an odometry link.
Eigen::Vector3d relativePose(const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                             Eigen::Matrix3d* J_a = nullptr, Eigen::Matrix3d* J_b = nullptr);

}  // namespace ekf_slam
