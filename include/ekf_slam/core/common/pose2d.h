// Planar rigid transforms (x, y, yaw) and yaw quaternions, shared by the relocalisers, the
// simulator and the ROS conversions. ROS-free.
#pragma once

#include <cmath>

#include <Eigen/Core>

#include "ekf_slam/core/common/angles.h"

namespace ekf_slam {

/// The 2D rotation by `a` [rad].
inline Eigen::Matrix2d rotation2d(double a) {
  const double c = std::cos(a), s = std::sin(a);
  Eigen::Matrix2d r;
  r << c, -s, s, c;
  return r;
}

/// a (+) b: the pose b, given in the frame of a, in a's parent frame (yaw wrapped).
inline Eigen::Vector3d composePose(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  const Eigen::Vector2d t = a.head<2>() + rotation2d(a.z()) * b.head<2>();
  return {t.x(), t.y(), wrapAngle(a.z() + b.z())};
}

/// The inverse transform: composePose(a, inversePose(a)) is the identity.
inline Eigen::Vector3d inversePose(const Eigen::Vector3d& a) {
  const Eigen::Vector2d t = -(rotation2d(a.z()).transpose() * a.head<2>());
  return {t.x(), t.y(), -a.z()};
}

/// Covariance of anchor o u, u the motion an estimate with heading `estimate_yaw` integrated (Q its
/// noise, in that estimate's map frame): d/d anchor = [I, S R u_xy; 0 1] (S the 90 degree turn),
/// and Q turned from the estimate's frame into the anchor's. The odometry since a scan, a held
/// relocalisation fix moved to now and a fix carried back to a tracked scan are all this.
inline Eigen::Matrix3d carriedCovariance(const Eigen::Vector3d& anchor,
                                         const Eigen::Matrix3d& anchor_cov,
                                         const Eigen::Vector3d& u, double estimate_yaw,
                                         const Eigen::Matrix3d& Q) {
  const Eigen::Vector2d lever = rotation2d(anchor.z()) * u.head<2>();
  Eigen::Matrix3d Ja = Eigen::Matrix3d::Identity();
  Ja(0, 2) = -lever.y();
  Ja(1, 2) = lever.x();
  Eigen::Matrix3d Jr = Eigen::Matrix3d::Identity();
  Jr.topLeftCorner<2, 2>() = rotation2d(anchor.z() - estimate_yaw);
  return Ja * anchor_cov * Ja.transpose() + Jr * Q * Jr.transpose();
}

/// A planar rotation by `yaw` as a unit quaternion (x, y, z, w) = (0, 0, sin(yaw/2), cos(yaw/2)).
inline Eigen::Vector4d yawQuaternion(double yaw) {
  return {0.0, 0.0, std::sin(0.5 * yaw), std::cos(0.5 * yaw)};
}

/// The yaw of a quaternion (x, y, z, w). The atan2 form w^2 + x^2 - y^2 - z^2 (instead of
/// 1 - 2 (y^2 + z^2)) is invariant to the quaternion's scale, so a slightly unnormalised message
/// gives the right yaw.
inline double quaternionYaw(double x, double y, double z, double w) {
  return std::atan2(2.0 * (w * z + x * y), w * w + x * x - y * y - z * z);
}

}  // namespace ekf_slam
