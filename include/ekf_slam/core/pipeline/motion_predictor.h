// The odometry side of the pipeline: odometry messages in, one composed motion step out per scan.
//
// Prediction is lazy: the motion steps of the odometry messages between two scans are composed
// into one MotionStep (F = F2 F1, Q = F2 Q1 F2^T + Q2, exact; with odometry correction states
// their Jacobians and noise compose along, see compose()) and applied to the filter once, right
// before the scan is associated. Per-message work is O(1) and allocation-free. pose() and
// poseCovariance() include the pending motion.
//
// Time handling (docs/parameters.md, "Input ordering"):
//  - twist mode: the twist of message k holds over [t_k, t_k+1] (zero-order hold, as
//    victoria_park_to_bag integrates its /odom poses). Before the first odometry message the
//    vehicle is assumed still.
//  - pose_delta mode: the increment between consecutive odometry poses drives PoseDeltaModel. A
//    scan between two messages is reached by extrapolating the last odometry pose with that
//    message's twist (exact arc); the next increment then starts from the extrapolated pose, so
//    the increments still add up to the odometry's own.
//  - non-finite odometry: rejected and counted. Odometry older than the filter time (late, or a
//    backwards jump): skipped and counted (its interval is already predicted).
//  - a scan older than the filter time (late): processed at the filter's current time, counted,
//    flagged in ScanReport::late.
#pragma once

#include <limits>

#include <Eigen/Core>

#include "ekf_slam/core/filter/ekf_slam.h"
#include "ekf_slam/core/filter/motion_models.h"
#include "ekf_slam/core/filter/odometry_correction.h"
#include "ekf_slam/core/pipeline/odometry_input.h"
#include "ekf_slam/core/pipeline/pipeline_config.h"
#include "ekf_slam/core/pipeline/scan_report.h"

namespace ekf_slam {

class MotionPredictor {
 public:
  /// `filter`: the state the motion starts from (its pose and correction estimates are read);
  /// `counters`: where refused odometry and late scans are counted.
  MotionPredictor(const PipelineConfig& config, const EkfSlam& filter, PipelineCounters& counters);

  /// No time, no odometry, nothing pending, the odometry since the last scan forgotten.
  void reset();

  /// One odometry message; false (counted) when it is refused.
  bool add(const OdometryInput& odom);
  /// The stamp a scan is processed at, and the motion up to it composed: a non-finite stamp or
  /// one older than time() is used at time() (late, counted).
  double advanceToScan(double stamp, ScanReport* report);

  /// Motion composed since the filter was last predicted.
  bool pending() const { return pending_steps_ > 0; }
  const MotionStep& step() const { return pending_; }
  /// The pending step is being applied to the filter (still holding the pose before it): the
  /// odometry alone and the motion since the last scan take it in; nothing is pending after.
  void applied();

  /// Current pose estimate at time(), including the pending motion. O(1).
  Eigen::Vector3d pose() const { return pending_steps_ > 0 ? pending_.pose : filter_.pose(); }
  /// Its covariance, F P_vv F^T + Q of the pending motion. O(1).
  Eigen::Matrix3d poseCovariance() const;
  /// Stamp the motion has been composed to (NaN before any input).
  double time() const { return time_; }
  /// The odometry correction model (mode none: no states).
  const OdometryCorrection& correction() const { return correction_; }
  /// The odometry alone integrated (the estimate's motion without updates, jumps or fixes), in
  /// an arbitrary frame: the relative motion between any two scans.
  const Eigen::Vector3d& odometry() const { return odometry_; }
  /// Gives the report the odometry since the previous numbered scan (ScanReport::motion) and
  /// starts counting again.
  void takeMotion(ScanReport* report);

 private:
  void advanceTo(double stamp);
  void composeStep(double dt);
  void composePoseDelta(const Eigen::Vector3d& delta);
  /// pending_ <- step o pending_ (a non-finite step is counted as rejected odometry).
  void compose(const MotionStep& step);
  /// The pending step's Q_translation and Q_rotation with `step` composed on (before F is).
  void composeTerms(const MotionStep& step);

  const PipelineConfig& config_;
  const EkfSlam& filter_;
  TwistModel twist_model_;
  PoseDeltaModel pose_delta_model_;
  OdometryCorrection correction_;
  PipelineCounters& counters_;

  double time_ = std::numeric_limits<double>::quiet_NaN();
  bool have_odometry_ = false;
  OdometryInput last_odom_;
  /// pose_delta mode: odometry-frame pose at time_ (last_odom_.pose extrapolated to time_).
  Eigen::Vector3d odom_pose_at_time_ = Eigen::Vector3d::Zero();
  // Composed motion since the last prediction (pose at time_, F, Q).
  MotionStep pending_;
  int pending_steps_ = 0;
  Eigen::Vector3d odometry_ = Eigen::Vector3d::Zero();
  // The odometry since the last numbered scan; valid once a scan was numbered since reset().
  Eigen::Vector3d motion_ = Eigen::Vector3d::Zero();
  Eigen::Matrix3d motion_covariance_ = Eigen::Matrix3d::Zero();
  Eigen::Matrix3d motion_translation_ = Eigen::Matrix3d::Zero();  // its noise terms' shares
  Eigen::Matrix3d motion_rotation_ = Eigen::Matrix3d::Zero();
  bool motion_valid_ = false;
};

}  // namespace ekf_slam
