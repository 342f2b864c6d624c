// pluginlib registration of every data associator. Lookup names ("ekf_slam/DJNN", ...) are
// declared in association_plugins.xml at the package root, exported from package.xml.
#include <pluginlib/class_list_macros.hpp>

#include "ekf_slam/core/association/data_association.h"
#include "ekf_slam/core/association/djnn/djnn.h"
#include "ekf_slam/core/association/hungarian.h"
#include "ekf_slam/core/association/jcbb.h"
#include "ekf_slam/core/association/nn.h"
#include "ekf_slam/core/association/nnjcbb.h"
#include "ekf_slam/core/association/rrwsc.h"

PLUGINLIB_EXPORT_CLASS(ekf_slam::NN, ekf_slam::DataAssociation)
PLUGINLIB_EXPORT_CLASS(ekf_slam::JCBB, ekf_slam::DataAssociation)
PLUGINLIB_EXPORT_CLASS(ekf_slam::DJNN, ekf_slam::DataAssociation)
PLUGINLIB_EXPORT_CLASS(ekf_slam::NNJCBB, ekf_slam::DataAssociation)
PLUGINLIB_EXPORT_CLASS(ekf_slam::Hungarian, ekf_slam::DataAssociation)
PLUGINLIB_EXPORT_CLASS(ekf_slam::RRWSC, ekf_slam::DataAssociation)
