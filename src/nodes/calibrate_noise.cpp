// Noise calibration from a bag: ekf_slam/tools/calibrate_noise.h, docs/calibration.md.
#include "ekf_slam/tools/calibrate_noise.h"

int main(int argc, char** argv) { return ekf_slam::calibrateNoiseMain(argc, argv); }
