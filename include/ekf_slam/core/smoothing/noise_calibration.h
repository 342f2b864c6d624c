// Noise calibration of a finished run: the factor by which each configured noise term (odometry
// translation and rotation; observation range and bearing, or the sensor's own covariance) should
// be scaled so that the batch smoother's residuals of that term are as large as the model says.
// ROS-free (Eigen only). docs/calibration.md.
//
// Why not the cost per residual: at the smoother's solution a residual is smaller than its noise,
// because the fit absorbed part of it (its leverage J N^-1 J^T); the share absorbed differs per
// term (a landmark seen twice absorbs half its observations' noise, a long odometry chain little).
// The estimate is variance component estimation (Foerstner's iteration): with C = sum_t theta_t
// C_t, each term's weighted cost v^T W (theta_t C_t) W v is compared with its expected value under
// the model, tr(W theta_t C_t) - tr(W theta_t C_t W J N^-1 J^T); theta_t is multiplied by their
// ratio, the run smoothed again with the new weights, until every ratio is 1. The leverage comes
// from the smoother (SmootherParams::residuals), exact.
#pragma once

#include <array>
#include <cstddef>
#include <string>
#include <vector>

#include "ekf_slam/core/filter/observation_model.h"
#include "ekf_slam/core/smoothing/batch_smoother.h"

namespace ekf_slam {

/// The noise terms a run's residuals are split into.
enum class NoiseTerm : int {
  kOdometryTranslation = 0,  ///< twist_sigma_v, twist_sigma_v_per_v (pose_delta_alpha_trans_*)
  kOdometryRotation,         ///< twist_sigma_w, twist_sigma_w_per_v (pose_delta_alpha_rot_*)
  kRange,                    ///< sigma_range (observations with the default covariance)
  kBearing,                  ///< sigma_bearing (the same; Cartesian ones carried to x, y)
  kOwnRange,                 ///< the range of observations that bring their own covariance
  kOwnBearing,               ///< ... their bearing
  kOwnX,                     ///< Cartesian observations with their own covariance: x
  kOwnY,                     ///< ... y
  kCount
};
constexpr int kNoiseTerms = static_cast<int>(NoiseTerm::kCount);
const char* noiseTermName(NoiseTerm term);

struct NoiseCalibrationParams {
  /// The pipeline's default observation noise (PipelineConfig::sigma_range, sigma_bearing): how
  /// a Cartesian observation's default covariance splits into its range and bearing terms.
  double sigma_range = 0.5;
  double sigma_bearing = 0.01745;
  int max_iterations = 60;
  /// Converged when every term's cost is within this fraction of its expected value.
  double tolerance = 2e-3;
  /// A term whose expected cost (its effective degrees of freedom: what the fit leaves of its
  /// residuals) is below this while its cost says it should shrink is not calibrated: the run
  /// does not determine it (a variance estimated from k dof has a relative spread of
  /// sqrt(2 / k), 14 % at 100), and Foerstner's iteration drives such a variance to zero. Its
  /// factor stays 1.
  double min_dof = 100.0;
};

struct NoiseTermEstimate {
  std::size_t residuals = 0;  ///< scalar residuals with a share of this term
  /// The term's weighted cost over its expected value: with the noise as given (before) and at
  /// the calibrated noise (after, 1 when converged). Its square root is roughly the factor.
  double ratio_before = 0.0;
  double ratio_after = 0.0;
  /// The expected cost with the noise as given over the number of scalar residuals: the share
  /// of its degrees of freedom the smoother leaves to the term (below 1: part was fitted away).
  double dof_share = 0.0;
  double effective_dof = 0.0;  ///< dof_share x residuals
  /// Seen but not calibrated: too few effective dof (NoiseCalibrationParams::min_dof).
  bool undetermined = false;
  /// theta: the term's covariance should be multiplied by this; `factor` = sqrt(theta) for its
  /// standard deviations. 1 for a term without residuals or with no share of the covariance.
  double variance_factor = 1.0;
  double factor = 1.0;
  bool calibrated = false;  ///< had residuals and a share of their covariance
};

struct NoiseCalibrationResult {
  bool ok = false;
  std::string error;
  std::array<NoiseTermEstimate, kNoiseTerms> terms;
  int iterations = 0;
  bool converged = false;
  /// The smoother's cost per degree of freedom with the noise as given and as calibrated.
  double cost_per_dof_before = 0.0;
  double cost_per_dof_after = 0.0;
  std::size_t degrees_of_freedom = 0;
  SmoothingResult smoothing;  ///< the last smoothing (calibrated noise)
};

/// Calibrates the noise terms of a recorded run (SmoothingRecorder::scans(), landmarks()).
NoiseCalibrationResult calibrateNoise(const std::vector<SmoothingScan>& scans,
                                      const std::vector<SmoothingLandmark>& landmarks,
                                      const RangeBearingModel& model,
                                      const NoiseCalibrationParams& params = {});

}  // namespace ekf_slam
