// ekf_slam_offline --bag FILE --out DIR [--params YAML] [--associator NAME] [--dump-problem SCAN]
// Replays a bag through the SLAM pipeline without a ROS master (see offline_runner.h).
#include "ekf_slam/ros/offline/offline_runner.h"

int main(int argc, char** argv) { return ekf_slam::offlineMain(argc, argv); }
