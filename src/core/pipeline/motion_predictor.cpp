#include "ekf_slam/core/pipeline/motion_predictor.h"

#include <cmath>

#include "ekf_slam/core/common/pose2d.h"

namespace ekf_slam {

namespace {

bool finite(const MotionStep& s) {
  return s.pose.allFinite() && s.F.allFinite() && s.Q.allFinite() && s.Fc.allFinite() &&
         s.Qvc.allFinite() && s.Qc.allFinite();
}

}  // namespace

MotionPredictor::MotionPredictor(const PipelineConfig& config, const EkfSlam& filter,
                                 PipelineCounters& counters)
    : config_(config),
      filter_(filter),
      twist_model_(config.twist),
      pose_delta_model_(config.pose_delta),
      correction_(config.correction),
      counters_(counters) {}

void MotionPredictor::reset() {
  time_ = std::numeric_limits<double>::quiet_NaN();
  have_odometry_ = false;
  last_odom_ = OdometryInput();
  odom_pose_at_time_.setZero();
  pending_steps_ = 0;
  motion_valid_ = false;
  motion_.setZero();
  motion_covariance_.setZero();
  motion_translation_.setZero();
  motion_rotation_.setZero();
}

Eigen::Matrix3d MotionPredictor::poseCovariance() const {
  if (pending_steps_ == 0) return filter_.poseCovariance();
  const Eigen::Matrix3d Pvv = filter_.poseCovariance();
  Eigen::Matrix3d P = pending_.F * Pvv * pending_.F.transpose() + pending_.Q;
  if (const int k = pending_.corrections; k > 0) {
    // [F Fc] P_aa [F Fc]^T + Q: the cross and correction blocks of the vehicle part.
    const auto Pf = filter_.storedCovariance();  // a view: its vehicle rows are current
    using Cols = Eigen::Matrix<double, 3, Eigen::Dynamic, 0, 3, kMaxCorrectionStates>;
    const Cols FPvc = pending_.F * Pf.block(0, 3, 3, k);
    const Cols Fc = pending_.Fc.leftCols(k);
    P += FPvc * Fc.transpose() + Fc * FPvc.transpose() + Fc * Pf.block(3, 3, k, k) * Fc.transpose();
  }
  return 0.5 * (P + P.transpose());
}

void MotionPredictor::applied() {
  // The odometry alone, for re-deriving past poses from a fix, and since the last scan, for a
  // smoother (ScanReport::motion).
  const Eigen::Vector3d delta = composePose(inversePose(filter_.pose()), pending_.pose);
  odometry_ = composePose(odometry_, delta);
  motion_covariance_ =
      carriedCovariance(motion_, motion_covariance_, delta, filter_.pose().z(), pending_.Q);
  // Its shares by noise term, carried the same (linear) way.
  motion_translation_ = carriedCovariance(motion_, motion_translation_, delta, filter_.pose().z(),
                                          pending_.Q_translation);
  motion_rotation_ =
      carriedCovariance(motion_, motion_rotation_, delta, filter_.pose().z(), pending_.Q_rotation);
  motion_ = composePose(motion_, delta);
  pending_steps_ = 0;
}

void MotionPredictor::takeMotion(ScanReport* report) {
  report->has_motion = motion_valid_;
  report->motion = motion_;
  report->motion_covariance = motion_covariance_;
  report->motion_covariance_translation = motion_translation_;
  report->motion_covariance_rotation = motion_rotation_;
  motion_valid_ = true;
  motion_.setZero();
  motion_covariance_.setZero();
  motion_translation_.setZero();
  motion_rotation_.setZero();
}

void MotionPredictor::compose(const MotionStep& s) {
  if (!finite(s)) {
    ++counters_.rejected_odometry;
    return;
  }
  if (pending_steps_ == 0) {
    pending_ = s;
  } else if (s.corrections == 0) {
    // P' = F2 (F1 P F1^T + Q1) F2^T + Q2 = (F2 F1) P (F2 F1)^T + (F2 Q1 F2^T + Q2): exact, and
    // the pose-map block F2 F1 P_vm likewise.
    pending_.pose = s.pose;
    pending_.Q = s.F * pending_.Q * s.F.transpose() + s.Q;
    composeTerms(s);
    pending_.F = s.F * pending_.F;
  } else {
    // With correction states c (constant in a prediction, plus a random walk) each step is
    // A = [F Fc; 0 I] with noise N = [Q Qvc; Qvc^T Qc]; A2 A1 and A2 N1 A2^T + N2 give
    //   F = F2 F1, Fc = F2 Fc1 + Fc2, Qc = Qc1 + Qc2, Qvc = F2 Qvc1 + Fc2 Qc1 (+ Qvc2),
    //   Q = F2 Q1 F2^T + F2 Qvc1 Fc2^T + Fc2 Qvc1^T F2^T + Fc2 Qc1 Fc2^T + Q2.
    const Eigen::Matrix<double, 3, 2> F2Qvc1 = s.F * pending_.Qvc;
    pending_.pose = s.pose;
    pending_.Q = s.F * pending_.Q * s.F.transpose() + F2Qvc1 * s.Fc.transpose() +
                 s.Fc * F2Qvc1.transpose() + s.Fc * pending_.Qc * s.Fc.transpose() + s.Q;
    pending_.Qvc = F2Qvc1 + s.Fc * pending_.Qc + s.Qvc;
    pending_.Qc += s.Qc;
    composeTerms(s);  // the odometry's own noise terms carry no correction-state share
    pending_.Fc = s.F * pending_.Fc + s.Fc;
    pending_.F = s.F * pending_.F;
  }
  ++pending_steps_;
}

void MotionPredictor::composeTerms(const MotionStep& s) {
  pending_.Q_translation = s.F * pending_.Q_translation * s.F.transpose() + s.Q_translation;
  pending_.Q_rotation = s.F * pending_.Q_rotation * s.F.transpose() + s.Q_rotation;
}

void MotionPredictor::composeStep(double dt) {
  if (correction_.dim() == 0) {
    compose(twist_model_.step(pose(), last_odom_.twist, dt));
    return;
  }
  // The twist the vehicle drove according to the current correction estimate (a prediction
  // does not move the estimate, so the filter's mean is current even with motion pending); the
  // pose's Jacobian w.r.t. the states is G dtwist'/dc.
  Eigen::Matrix2d J;
  const Eigen::Vector2d u = correction_.apply(last_odom_.twist, filter_.correction(), &J);
  Eigen::Matrix<double, 3, 2> G;
  MotionStep s = twist_model_.step(pose(), u, dt, &G);
  s.corrections = correction_.dim();
  s.Fc = G * J;
  s.Qc = correction_.randomWalk(dt);
  compose(s);
}

void MotionPredictor::composePoseDelta(const Eigen::Vector3d& delta) {
  compose(pose_delta_model_.step(pose(), delta));
}

void MotionPredictor::advanceTo(double stamp) {
  if (std::isfinite(time_) && have_odometry_) {
    const double dt = stamp - time_;
    if (dt > 0.0) {
      if (config_.odometry_mode == "pose_delta") {
        // Where the odometry would be at `stamp`: its last pose moved on with its twist.
        const Eigen::Vector3d extrapolated =
            twist_model_.predict(odom_pose_at_time_, last_odom_.twist, dt);
        composePoseDelta(PoseDeltaModel::between(odom_pose_at_time_, extrapolated));
        odom_pose_at_time_ = extrapolated;
      } else {
        composeStep(dt);
      }
    }
  }
  // Before the first odometry message the vehicle is taken to be still.
  time_ = stamp;
}

bool MotionPredictor::add(const OdometryInput& odom) {
  const bool pose_delta = config_.odometry_mode == "pose_delta";
  if (!std::isfinite(odom.stamp) || !odom.twist.allFinite() ||
      (pose_delta && !odom.pose.allFinite())) {
    ++counters_.rejected_odometry;
    return false;
  }
  // Finite but physically impossible (1e300 m/s would move the pose to infinity): not driven.
  if (std::abs(odom.twist(0)) > config_.max_speed ||
      std::abs(odom.twist(1)) > config_.max_yaw_rate) {
    ++counters_.implausible_odometry;
    return false;
  }
  if (pose_delta && !odom.orientation_valid) {
    ++counters_.invalid_orientations;
    return false;
  }
  if (std::isfinite(time_) && odom.stamp < time_) {
    ++counters_.late_odometry;
    return false;
  }
  ++counters_.odometry;
  if (have_odometry_) {
    if (odom.stamp - last_odom_.stamp > config_.max_odometry_gap) ++counters_.odometry_gaps;
    if (pose_delta) {
      composePoseDelta(PoseDeltaModel::between(odom_pose_at_time_, odom.pose));
      time_ = odom.stamp;
    } else {
      advanceTo(odom.stamp);  // the previous twist holds up to this message
    }
  } else {
    time_ = odom.stamp;
    have_odometry_ = true;
  }
  last_odom_ = odom;
  odom_pose_at_time_ = odom.pose;
  return true;
}

double MotionPredictor::advanceToScan(double stamp, ScanReport* report) {
  if (!std::isfinite(stamp)) {
    ++counters_.invalid_stamps;
    report->late = true;
    stamp = std::isfinite(time_) ? time_ : 0.0;
  } else if (std::isfinite(time_) && stamp < time_) {
    ++counters_.late_scans;
    report->late = true;
    stamp = time_;
  }
  if (!have_odometry_) ++counters_.scans_before_odometry;
  advanceTo(stamp);
  return stamp;
}

}  // namespace ekf_slam
