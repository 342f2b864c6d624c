// scan_filter_chain (laser_filters' shape: a list of {name, type, params}) from a YAML file, for
// the ROS-free tools and the offline runner; the node reads the same list from the parameter
// server (ros/extractor_loader.h).
#pragma once

#include <string>
#include <vector>

#include "ekf_slam/core/feature_extraction/scan_filter_chain.h"

namespace ekf_slam {

/// The chain under `scan_filter_chain` in the YAML file `path` (empty when unset or no path).
/// Throws ParameterError for a malformed entry, std::runtime_error for an unreadable file.
std::vector<ScanFilterSpec> readScanFilterChainFile(const std::string& path);
/// The same from YAML text; `origin` names it in errors.
std::vector<ScanFilterSpec> readScanFilterChainText(const std::string& text,
                                                    const std::string& origin = "<yaml>");

}  // namespace ekf_slam
