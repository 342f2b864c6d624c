// One odometry message as the pipeline takes it (nav_msgs/Odometry without ROS).
#pragma once

#include <Eigen/Core>

namespace ekf_slam {

/// One odometry message.
struct OdometryInput {
  double stamp = 0.0;
  Eigen::Vector2d twist = Eigen::Vector2d::Zero();  ///< (v, w) of base_link
  Eigen::Vector3d pose = Eigen::Vector3d::Zero();   ///< (x, y, yaw) in the odometry frame
  /// False when the message's orientation carries no rotation (an all-zero or non-finite
  /// quaternion): its pose cannot drive pose_delta mode.
  bool orientation_valid = true;
};

}  // namespace ekf_slam
