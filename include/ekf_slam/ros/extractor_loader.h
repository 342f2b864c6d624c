// The laser scan and the scan filter chain from ROS: LaserScan -> LaserScanData, and the chain
// from the parameter server (`scan_filter_chain`, docs/feature_extraction.md).
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

/// The chain under `key` of the parameter server (a list of {name, type, params}); empty when
/// unset. Throws ParameterError for a malformed entry.
std::vector<ScanFilterSpec> readScanFilterChain(const ros::NodeHandle& nh,
                                                const std::string& key = "scan_filter_chain");

/// The scan's data for the extractor (ranges, intensities, angles, range limits).
LaserScanData toScanData(const sensor_msgs::LaserScan& scan);

}  // namespace ekf_slam
