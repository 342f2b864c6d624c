#include "ekf_slam/tools/relocalisation_experiment.h"

int main(int argc, char** argv) { return ekf_slam::relocalisationExperimentMain(argc, argv); }
