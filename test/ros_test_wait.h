// Waiting for a condition while spinning ROS callbacks, for the rostests.
#pragma once

#include <functional>

#include <ros/ros.h>

namespace test_files {

/// Spins until done() holds or `seconds` of wall time pass; returns done().
inline bool waitFor(const std::function<bool()>& done, double seconds, double poll_s = 0.005) {
  const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(seconds);
  while (ros::ok() && ros::WallTime::now() < deadline) {
    ros::spinOnce();
    if (done()) return true;
    ros::WallDuration(poll_s).sleep();
  }
  ros::spinOnce();
  return done();
}

}  // namespace test_files
