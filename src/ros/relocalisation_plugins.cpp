// pluginlib registration of the relocalisers. Lookup names ("ekf_slam/RRWSC", ...) are declared
// in relocalisation_plugins.xml at the package root, exported from package.xml.
#include <pluginlib/class_list_macros.hpp>

#include "ekf_slam/core/relocalisation/relocaliser.h"
#include "ekf_slam/core/relocalisation/rrwsc_relocaliser.h"

PLUGINLIB_EXPORT_CLASS(ekf_slam::RRWSCRelocaliser, ekf_slam::Relocaliser)
