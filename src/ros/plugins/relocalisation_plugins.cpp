// pluginlib registration of every relocaliser. Lookup names ("ekf_slam/FGCBB", ...) are declared
// in relocalisation_plugins.xml at the package root, exported from package.xml.
#include <pluginlib/class_list_macros.hpp>

#include "ekf_slam/core/relocalisation/fgcbb.h"
#include "ekf_slam/core/relocalisation/gcbb.h"
#include "ekf_slam/core/relocalisation/relocaliser.h"
#include "ekf_slam/core/relocalisation/rrwsc_relocaliser.h"

PLUGINLIB_EXPORT_CLASS(ekf_slam::FGCBB, ekf_slam::Relocaliser)
PLUGINLIB_EXPORT_CLASS(ekf_slam::GCBB, ekf_slam::Relocaliser)
PLUGINLIB_EXPORT_CLASS(ekf_slam::RRWSCRelocaliser, ekf_slam::Relocaliser)
