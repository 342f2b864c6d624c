// Planar rigid transforms (x, y, yaw), shared by the relocalisers and the ROS node. ROS-free.
#pragma once

#include <cmath>

#include <Eigen/Core>

#include "ekf_slam/core/angles.h"

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

}  // namespace ekf_slam
