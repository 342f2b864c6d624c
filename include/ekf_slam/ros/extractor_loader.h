// Feature extractor and scan filter chain set-up shared by the node, the offline runner and
// detect_features: the plugin by name from its own section, the chain from
// `scan_filter_chain` (docs/feature_extraction.md).
#pragma once

#include <memory>
#include <string>
#include <vector>

#include <ros/node_handle.h>
#include <sensor_msgs/LaserScan.h>

#include "ekf_slam/core/feature_extraction/feature_extractor.h"
#include "ekf_slam/core/feature_extraction/scan_filter_chain.h"
#include "ekf_slam/ros/plugin_loader.h"

namespace ekf_slam {

/// Creates the extractor `name` configured from its own section (`section`, e.g. ~BeaconExtractor).
/// TreeExtractor's entries fall back on its historical top-level names (extractor_max_range, ...)
/// in `top`, so every existing config behaves as before.
std::shared_ptr<FeatureExtractor> createFeatureExtractor(const ExtractorLoader& loader,
                                                         const std::string& name,
                                                         const ParameterSource& section,
                                                         const ParameterSource& top);

/// The chain under `key` of the parameter server (a list of {name, type, params}); empty when
/// unset. Throws ParameterError for a malformed entry.
std::vector<ScanFilterSpec> readScanFilterChain(const ros::NodeHandle& nh,
                                                const std::string& key = "scan_filter_chain");

/// The scan's data for the extractor (ranges, intensities, angles, range limits).
LaserScanData toScanData(const sensor_msgs::LaserScan& scan);

}  // namespace ekf_slam
