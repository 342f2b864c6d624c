// rosrun ekf_slam ekf_slam: the EKF-SLAM node (docs/node.md).
#include <ros/ros.h>

#include "ekf_slam/ros/node/ekf_slam_node.h"

int main(int argc, char** argv) {
  ros::init(argc, argv, "ekf_slam");
  return ekf_slam::runEkfSlamNode();
}
