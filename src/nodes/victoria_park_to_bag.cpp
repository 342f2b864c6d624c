// Victoria Park data set -> ROS bag. Run with --help for the options.
#include "ekf_slam/ros/victoria_park_bag.h"

int main(int argc, char** argv) {
  return ekf_slam::victoria_park::victoriaParkToBagMain(argc, argv);
}
