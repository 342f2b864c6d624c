// pluginlib registration of every feature extractor. Lookup names ("ekf_slam/TreeExtractor", ...)
// are declared in extraction_plugins.xml at the package root, exported from package.xml.
#include <pluginlib/class_list_macros.hpp>

#include "ekf_slam/core/feature_extraction/beacon_extractor.h"
#include "ekf_slam/core/feature_extraction/feature_extractor.h"
#include "ekf_slam/core/feature_extraction/tree_feature_extractor.h"

PLUGINLIB_EXPORT_CLASS(ekf_slam::TreeFeatureExtractor, ekf_slam::FeatureExtractor)
PLUGINLIB_EXPORT_CLASS(ekf_slam::BeaconExtractor, ekf_slam::FeatureExtractor)
