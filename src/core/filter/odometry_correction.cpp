// Odometry correction states of the augmented EKF: corrected twist and its Jacobians.
#include "ekf_slam/core/filter/odometry_correction.h"

#include <cmath>

#include "ekf_slam/core/common/parameters.h"

namespace ekf_slam {

namespace {

const char* const kModes[] = {"none", "speed_scale", "speed_scale_yaw_bias", "wheel_factors"};

}  // namespace

void OdometryCorrectionParams::validate() const {
  bool known = false;
  for (const char* m : kModes) known = known || mode == m;
  if (!known) {
    throw ParameterError(
        "parameter odometry_correction: must be one of {none, speed_scale, "
        "speed_scale_yaw_bias, wheel_factors}, got '" +
        mode + "'");
  }
  const auto positive = [](double v, const std::string& name) {
    requireParameter(std::isfinite(v) && v > 0.0, name, "must be finite and > 0", v);
  };
  const auto nonNegative = [](double v, const std::string& name) {
    requireParameter(std::isfinite(v) && v >= 0.0, name, "must be finite and >= 0", v);
  };
  positive(factor_min, "correction_factor_min");
  requireParameter(std::isfinite(factor_max) && factor_max > factor_min, "correction_factor_max",
                   "must be finite and > correction_factor_min", factor_max);
  positive(yaw_bias_max, "correction_yaw_bias_max");
  const auto inFactorBounds = [this](double v, const std::string& name) {
    requireParameter(std::isfinite(v) && v >= factor_min && v <= factor_max, name,
                     "must lie in [correction_factor_min, correction_factor_max]", v);
  };
  inFactorBounds(speed_scale_initial, "correction_speed_scale_initial");
  inFactorBounds(wheel_factor_initial, "correction_wheel_factor_initial");
  requireParameter(std::isfinite(yaw_bias_initial) && std::abs(yaw_bias_initial) <= yaw_bias_max,
                   "correction_yaw_bias_initial", "must lie in [-yaw_bias_max, yaw_bias_max]",
                   yaw_bias_initial);
  // A zero initial std dev would pin a state for good (the filter could never move it).
  positive(speed_scale_sigma, "correction_speed_scale_sigma");
  positive(yaw_bias_sigma, "correction_yaw_bias_sigma");
  positive(wheel_factor_sigma, "correction_wheel_factor_sigma");
  nonNegative(speed_scale_noise, "correction_speed_scale_noise");
  nonNegative(yaw_bias_noise, "correction_yaw_bias_noise");
  nonNegative(wheel_factor_noise, "correction_wheel_factor_noise");
  positive(track_width, "correction_track_width");
}

OdometryCorrection::OdometryCorrection(const OdometryCorrectionParams& p) : p_(p) {
  p_.validate();
  if (p_.mode == "speed_scale") {
    mode_ = Mode::kSpeedScale;
    dim_ = 1;
  } else if (p_.mode == "speed_scale_yaw_bias") {
    mode_ = Mode::kSpeedScaleYawBias;
    dim_ = 2;
  } else if (p_.mode == "wheel_factors") {
    mode_ = Mode::kWheelFactors;
    dim_ = 2;
  }
}

std::vector<std::string> OdometryCorrection::names() const {
  switch (mode_) {
    case Mode::kSpeedScale:
      return {"speed_scale"};
    case Mode::kSpeedScaleYawBias:
      return {"speed_scale", "yaw_bias"};
    case Mode::kWheelFactors:
      return {"left_factor", "right_factor"};
    case Mode::kNone:
      break;
  }
  return {};
}

CorrectionPrior OdometryCorrection::prior() const {
  CorrectionPrior c;
  c.dim = dim_;
  const auto factor = [&](int i, double mean, double sigma) {
    c.mean(i) = mean;
    c.sigma(i) = sigma;
    c.lower(i) = p_.factor_min;
    c.upper(i) = p_.factor_max;
  };
  switch (mode_) {
    case Mode::kSpeedScaleYawBias:
      c.mean(1) = p_.yaw_bias_initial;
      c.sigma(1) = p_.yaw_bias_sigma;
      c.lower(1) = -p_.yaw_bias_max;
      c.upper(1) = p_.yaw_bias_max;
      [[fallthrough]];
    case Mode::kSpeedScale:
      factor(0, p_.speed_scale_initial, p_.speed_scale_sigma);
      break;
    case Mode::kWheelFactors:
      factor(0, p_.wheel_factor_initial, p_.wheel_factor_sigma);
      factor(1, p_.wheel_factor_initial, p_.wheel_factor_sigma);
      break;
    case Mode::kNone:
      break;
  }
  return c;
}

Eigen::Vector2d OdometryCorrection::apply(const Eigen::Vector2d& u, const Eigen::Vector2d& c,
                                          Eigen::Matrix2d* J) const {
  const double v = u(0);
  const double w = u(1);
  if (J) J->setZero();
  switch (mode_) {
    case Mode::kNone:
      return u;
    case Mode::kSpeedScale:
      if (J) J->col(0) << v, w;
      return c(0) * u;
    case Mode::kSpeedScaleYawBias: {
      const double s = c(0);
      const double k = c(1);
      if (J) *J << v, 0.0, w + k * v, s * v;
      return Eigen::Vector2d(s * v, s * (w + k * v));
    }
    case Mode::kWheelFactors: {
      const double B = p_.track_width;
      const double vl = v - 0.5 * w * B;
      const double vr = v + 0.5 * w * B;
      if (J) *J << 0.5 * vl, 0.5 * vr, -vl / B, vr / B;
      return Eigen::Vector2d(0.5 * (c(0) * vl + c(1) * vr), (c(1) * vr - c(0) * vl) / B);
    }
  }
  return u;
}

Eigen::Matrix2d OdometryCorrection::randomWalk(double dt) const {
  Eigen::Vector2d q = Eigen::Vector2d::Zero();
  switch (mode_) {
    case Mode::kSpeedScaleYawBias:
      q(1) = p_.yaw_bias_noise * p_.yaw_bias_noise;
      [[fallthrough]];
    case Mode::kSpeedScale:
      q(0) = p_.speed_scale_noise * p_.speed_scale_noise;
      break;
    case Mode::kWheelFactors:
      q.setConstant(p_.wheel_factor_noise * p_.wheel_factor_noise);
      break;
    case Mode::kNone:
      break;
  }
  return (q * dt).asDiagonal();
}

}  // namespace ekf_slam
