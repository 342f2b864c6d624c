// Vehicle motion models with their Jacobians and process noise. ROS-free (Eigen only).
//
// Every model maps a pose x = (x, y, yaw) and an input u over dt to a new pose, and gives
//   F = d f / d x (3x3),  G = d f / d u (3 x dim u)
// so that the EKF can propagate P_vv <- F P_vv F^T + Q with Q = G N G^T + Q_add, where N is the
// input noise covariance. The EKF itself never sees the model, only (pose, F, Q): see
// EkfSlam::predict.
#pragma once

#include <Eigen/Core>

namespace ekf_slam {

/// Result of one prediction step: the new pose, its Jacobian w.r.t. the old pose and the process
/// noise in pose space. With odometry correction states (AEKF, odometry_correction.h) the step
/// also carries the pose's Jacobian w.r.t. those states, the states' random walk and the
/// cross-covariance of the two noises (non-zero once steps are composed); the states themselves
/// do not change in a prediction.
struct MotionStep {
  Eigen::Vector3d pose;
  Eigen::Matrix3d F;
  Eigen::Matrix3d Q;
  /// The shares of Q from the model's translation (speed) noise and from its rotation (yaw-rate,
  /// steering) noise; Q less both is the rest (additive noise, the correction states' random
  /// walk). Each is linear in its term's variance, so noise calibration can scale the terms
  /// apart (core/smoothing/noise_calibration.h). Not used by the filter.
  Eigen::Matrix3d Q_translation = Eigen::Matrix3d::Zero();
  Eigen::Matrix3d Q_rotation = Eigen::Matrix3d::Zero();
  int corrections = 0;  ///< number of correction states (0: the plain EKF; the rest is unused)
  Eigen::Matrix<double, 3, 2> Fc = Eigen::Matrix<double, 3, 2>::Zero();   ///< d pose / d c
  Eigen::Matrix<double, 3, 2> Qvc = Eigen::Matrix<double, 3, 2>::Zero();  ///< cov(pose, c) noise
  Eigen::Matrix2d Qc = Eigen::Matrix2d::Zero();                           ///< random walk of c
};

/// Victoria Park Ackermann vehicle (ALGORITHMS.md section 1; seed 000 eq. 13-14). The tracked
/// point sits at (a, b) from the rear-axle centre (a forward, b to the left); with a = b = 0 it is
/// the rear-axle centre (base_link) and the laser offset is handled by the observation model.
/// Input u = (v_e, alpha): encoder speed on the wheel at lateral offset H, steering angle.
struct AckermannParams {
  double wheelbase = 2.83;       ///< L [m]
  double encoder_offset = 0.76;  ///< H [m], lateral offset of the encoder wheel
  double a = 0.0;                ///< forward offset of the tracked point [m]
  double b = 0.0;                ///< left offset of the tracked point [m]
  double sigma_speed = 0.5;      ///< std dev of v_e [m/s]
  double sigma_steering = 0.05;  ///< std dev of alpha [rad]
  Eigen::Matrix3d additive = Eigen::Matrix3d::Zero();  ///< extra pose noise per second
};

class AckermannModel {
 public:
  using Input = Eigen::Vector2d;  // (v_e, alpha)
  explicit AckermannModel(const AckermannParams& p = AckermannParams()) : p_(p) {}
  const AckermannParams& params() const { return p_; }

  /// v_c = v_e / (1 - tan(alpha) H / L): speed of the rear-axle centre.
  double rearAxleSpeed(double v_e, double alpha) const;
  /// yaw rate v_c / L tan(alpha).
  double yawRate(double v_e, double alpha) const;

  /// One Euler step of the ALGORITHMS.md section 1 equations. Optional Jacobians.
  Eigen::Vector3d predict(const Eigen::Vector3d& x, const Input& u, double dt,
                          Eigen::Matrix3d* F = nullptr,
                          Eigen::Matrix<double, 3, 2>* G = nullptr) const;
  /// predict() plus Q = G diag(sigma_speed^2, sigma_steering^2) G^T + additive * dt.
  MotionStep step(const Eigen::Vector3d& x, const Input& u, double dt) const;

 private:
  AckermannParams p_;
};

/// Unicycle driven by a twist u = (v, w): exact arc integration (straight line when w ~ 0).
struct TwistParams {
  double sigma_v = 0.1;                                ///< std dev of v [m/s] ...
  double sigma_v_per_v = 0.05;                         ///< ... plus this fraction of |v|
  double sigma_w = 0.02;                               ///< std dev of w [rad/s] ...
  double sigma_w_per_v = 0.01;                         ///< ... plus this many rad/s per m/s of |v|
  Eigen::Matrix3d additive = Eigen::Matrix3d::Zero();  ///< extra pose noise per second
  /// false: the sigmas are the std dev of the twist of each step (the pose noise per second then
  /// shrinks as the odometry rate grows). true: they are the square roots of the twist noise's
  /// spectral densities, [m/s sqrt(s)] and [rad/s sqrt(s)]: the step's twist noise is
  /// sigma^2 / dt, so the pose noise per second does not depend on the rate (docs/parameters.md).
  bool per_second = false;
  /// > 0: the odometry is a car-like vehicle's (speed and steering angle on this wheelbase L
  /// [m]), as in the simulator: the yaw-rate term sigma_w_per_v |v| is then a steering-angle
  /// noise of std dev sigma_w_per_v L, which reaches the yaw rate as v (1 + tan^2 delta) / L
  /// (tan delta = L w / v: it grows in turns), and the speed noise keeps the curvature (dw =
  /// w / v dv, correlated with v); tan delta is capped at 10. 0: independent v and w noise (a
  /// differential drive).
  double steering_wheelbase = 0.0;
};

class TwistModel {
 public:
  using Input = Eigen::Vector2d;  // (v, w)
  explicit TwistModel(const TwistParams& p = TwistParams()) : p_(p) {}
  const TwistParams& params() const { return p_; }

  Eigen::Vector3d predict(const Eigen::Vector3d& x, const Input& u, double dt,
                          Eigen::Matrix3d* F = nullptr,
                          Eigen::Matrix<double, 3, 2>* G = nullptr) const;
  /// predict() plus Q; optionally returns G = d pose / d u (for the correction states' chain).
  MotionStep step(const Eigen::Vector3d& x, const Input& u, double dt,
                  Eigen::Matrix<double, 3, 2>* G_out = nullptr) const;
  /// Covariance of the twist noise of one message with twist u (per_second: of its density;
  /// step() divides by dt): diagonal, or with steering_wheelbase the steering model's.
  Eigen::Matrix2d twistCovariance(const Input& u) const;
  /// twistCovariance() split into the share of the speed terms (sigma_v, sigma_v_per_v) and of
  /// the yaw-rate terms (sigma_w, sigma_w_per_v); they add up to it.
  void twistCovarianceTerms(const Input& u, Eigen::Matrix2d* speed, Eigen::Matrix2d* turn) const;

 private:
  TwistParams p_;
};

/// Pose-delta odometry: u = (dx, dy, dyaw) expressed in the vehicle frame at the start of the
/// step (what consecutive nav_msgs/Odometry poses give). Noise grows with the distance and the
/// rotation travelled (probabilistic-robotics style alphas).
struct PoseDeltaParams {
  double alpha_trans_per_trans = 0.05;  ///< translation std dev per metre travelled
  double alpha_trans_per_rot = 0.01;    ///< translation std dev [m] per rad turned
  double alpha_rot_per_rot = 0.05;      ///< rotation std dev per rad turned
  double alpha_rot_per_trans = 0.01;    ///< rotation std dev [rad] per metre travelled
  Eigen::Matrix3d additive = Eigen::Matrix3d::Zero();  ///< extra pose noise per step
};

class PoseDeltaModel {
 public:
  using Input = Eigen::Vector3d;  // (dx, dy, dyaw) in the vehicle frame
  explicit PoseDeltaModel(const PoseDeltaParams& p = PoseDeltaParams()) : p_(p) {}
  const PoseDeltaParams& params() const { return p_; }

  /// x' = x (+) u. dt is unused (the delta already spans the step); kept for a uniform API.
  Eigen::Vector3d predict(const Eigen::Vector3d& x, const Input& u, double dt = 0.0,
                          Eigen::Matrix3d* F = nullptr, Eigen::Matrix3d* G = nullptr) const;
  MotionStep step(const Eigen::Vector3d& x, const Input& u, double dt = 0.0) const;

  /// The delta between two odometry poses, in the frame of the first: (a^-1) (+) b.
  static Input between(const Eigen::Vector3d& a, const Eigen::Vector3d& b);

 private:
  PoseDeltaParams p_;
};

}  // namespace ekf_slam
