// rosrun ekf_slam evaluate --world NAME --runs 20 --associators A,B --out DIR  (docs/results.md)
#include "ekf_slam/tools/evaluate.h"

int main(int argc, char** argv) { return ekf_slam::evaluateMain(argc, argv); }
