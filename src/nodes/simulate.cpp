// Simulated world -> ROS bag + parameter YAML. Run with --help for the options.
#include "ekf_slam/tools/simulation_bag.h"

int main(int argc, char** argv) { return ekf_slam::simulateMain(argc, argv); }
