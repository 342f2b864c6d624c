// Odometry correction states of the augmented EKF (AEKF, ALGORITHMS.md section 8; seed 001
// paper 5), ROS-free. The EKF state becomes [x, y, yaw, c_1 .. c_k, landmarks] with k <= 2
// correction parameters that turn the reported twist (v, w) into the one the vehicle drove:
//
//   none                  k = 0: the plain EKF.
//   speed_scale           c = (s):        v' = s v,  w' = s w
//   speed_scale_yaw_bias  c = (s, kappa): v' = s v,  w' = s (w + kappa v)
//   wheel_factors         c = (d_l, d_r): wheel speeds v_l,r = v -/+ w B / 2 (track width B),
//                                         v' = (d_l v_l + d_r v_r) / 2,
//                                         w' = (d_r v_r - d_l v_l) / B
//
// The scale multiplies the whole twist because an encoder scale error (wheel radius) scales the
// yaw rate derived from it too. The yaw bias is a curvature [rad/m] (a steering bias of an
// Ackermann vehicle is kappa ~ d_alpha / L near straight; unequal wheel radii give one too): it
// vanishes when the vehicle stands still, unlike a constant yaw-rate bias, which would turn a
// parked vehicle. Each state is a random walk (noise std dev per sqrt(second)) with bounds: a
// scale or wheel factor is kept in [factor_min, factor_max] (> 0, so a correction never reverses
// the speed), the curvature bias in [-yaw_bias_max, yaw_bias_max].
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

namespace ekf_slam {

/// Upper bound on the number of correction states (fixed-size storage in the per-step path).
constexpr int kMaxCorrectionStates = 2;

struct OdometryCorrectionParams {
  /// none, speed_scale, speed_scale_yaw_bias or wheel_factors.
  std::string mode = "none";
  double speed_scale_initial = 1.0;
  double speed_scale_sigma = 0.1;   ///< initial std dev
  double speed_scale_noise = 1e-4;  ///< random walk [1/sqrt(s)]
  double yaw_bias_initial = 0.0;    ///< [rad/m]
  double yaw_bias_sigma = 0.01;     ///< [rad/m]
  double yaw_bias_noise = 1e-5;     ///< [rad/m/sqrt(s)]
  double wheel_factor_initial = 1.0;
  double wheel_factor_sigma = 0.31622776601683794;  ///< sqrt(0.1): the paper's variance 0.1
  double wheel_factor_noise = 1e-4;                 ///< [1/sqrt(s)]
  double track_width = 1.0;                         ///< B, wheel_factors only [m]
  double factor_min = 0.5;                          ///< bounds of scale and wheel factors
  double factor_max = 2.0;
  double yaw_bias_max = 0.1;  ///< [rad/m]

  /// Throws ParameterError naming the first invalid setting.
  void validate() const;
};

/// Mean, std devs and bounds of the correction states at the start (what EkfSlam::reset takes).
struct CorrectionPrior {
  int dim = 0;
  Eigen::Vector2d mean = Eigen::Vector2d::Zero();
  Eigen::Vector2d sigma = Eigen::Vector2d::Zero();
  Eigen::Vector2d lower = Eigen::Vector2d::Zero();
  Eigen::Vector2d upper = Eigen::Vector2d::Zero();
};

class OdometryCorrection {
 public:
  enum class Mode { kNone, kSpeedScale, kSpeedScaleYawBias, kWheelFactors };

  /// Throws ParameterError on invalid parameters.
  explicit OdometryCorrection(const OdometryCorrectionParams& p = OdometryCorrectionParams());

  Mode mode() const { return mode_; }
  int dim() const { return dim_; }
  const OdometryCorrectionParams& params() const { return p_; }
  /// Names of the states, e.g. {"left_factor", "right_factor"} (what the outputs call them).
  std::vector<std::string> names() const;
  CorrectionPrior prior() const;

  /// The corrected twist for correction states c (entries beyond dim() ignored) and, optionally,
  /// its Jacobian d twist' / d c (2 x 2, columns beyond dim() zero).
  Eigen::Vector2d apply(const Eigen::Vector2d& twist, const Eigen::Vector2d& c,
                        Eigen::Matrix2d* J = nullptr) const;
  /// Random-walk covariance of the states over dt (diagonal, zero beyond dim()).
  Eigen::Matrix2d randomWalk(double dt) const;

 private:
  OdometryCorrectionParams p_;
  Mode mode_ = Mode::kNone;
  int dim_ = 0;
};

}  // namespace ekf_slam
