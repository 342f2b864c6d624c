#include "ekf_slam/core/feature_extraction/feature_extractor.h"

namespace ekf_slam {

void FeatureExtractor::checkScan(const LaserScanData&) const {}

std::string intensityProblem(const LaserScanData& scan) {
  if (!scan.hasIntensities()) {
    return "the scan has no intensities (sensor_msgs/LaserScan.intensities is empty); use a "
           "laser driver that publishes them or an extractor that needs none";
  }
  if (scan.intensities.size() != scan.ranges.size()) {
    return "the scan has " + std::to_string(scan.intensities.size()) + " intensities for " +
           std::to_string(scan.ranges.size()) + " ranges";
  }
  return "";
}

}  // namespace ekf_slam
