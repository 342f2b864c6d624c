// A small chain of laser-scan filters applied before feature extraction, configured in
// laser_filters' YAML shape so that a user's existing chain works unchanged (Debian 12 does not
// package laser_filters):
//
//   scan_filter_chain:
//     - name: mask_vehicle
//       type: laser_filters/LaserScanBoxFilter
//       params: {min_x: -0.5, max_x: 3.0, min_y: -1.0, max_y: 1.0}
//
// A filtered beam becomes "no return" (+inf, REP 117) unless the filter's replacement value says
// otherwise; the beam count and angles never change, so extractors see the scan's geometry.
// Types, parameters and semantics: docs/feature_extraction.md.
#pragma once

#include <map>
#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "ekf_slam/core/common/parameters.h"
#include "ekf_slam/core/feature_extraction/feature_extractor.h"

namespace ekf_slam {

/// One filter of the chain.
class ScanFilter {
 public:
  virtual ~ScanFilter() = default;
  virtual void configure(const ParameterSource& params) = 0;
  virtual bool needsIntensities() const { return false; }
  /// Filters `scan` in place. `sensor_offset`: the laser's pose (x, y, yaw) on base_link.
  virtual void apply(LaserScanData* scan, const Eigen::Vector3d& sensor_offset) const = 0;
};

/// One entry of scan_filter_chain as read from YAML or the parameter server.
struct ScanFilterSpec {
  std::string name;
  std::string type;
  /// The filter's parameters (as strings) by name; a name no filter reads is an error.
  std::map<std::string, std::string> params;
};

class ScanFilterChain {
 public:
  /// The accepted `type` values (laser_filters' names), sorted.
  static std::vector<std::string> knownTypes();

  /// Appends a configured filter. Throws ParameterError for an unknown type (the message lists
  /// the known ones) or a bad parameter (named as scan_filter_chain/<name>/<param>).
  void add(const ScanFilterSpec& spec);
  /// A chain from its specs (in order).
  static ScanFilterChain fromSpecs(const std::vector<ScanFilterSpec>& specs);

  bool empty() const { return filters_.empty(); }
  std::size_t size() const { return filters_.size(); }
  const std::vector<std::string>& names() const { return names_; }
  bool needsIntensities() const;

  /// Applies every filter in order. Throws ScanFormatError when a filter needs intensities the
  /// scan lacks.
  void apply(LaserScanData* scan, const Eigen::Vector3d& sensor_offset) const;

 private:
  std::vector<std::shared_ptr<const ScanFilter>> filters_;
  std::vector<std::string> names_;
};

}  // namespace ekf_slam
