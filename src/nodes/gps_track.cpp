// rosrun ekf_slam gps_track: the GPS reference for rviz, broken at dropouts and jumps
// (docs/node.md, "The GPS reference").
#include <ros/ros.h>

#include "ekf_slam/ros/gps_track.h"

int main(int argc, char** argv) {
  ros::init(argc, argv, "gps_track");
  return ekf_slam::runGpsTrackNode();
}
