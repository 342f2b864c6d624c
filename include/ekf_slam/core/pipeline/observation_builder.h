// A scan's observations: the scan filter chain, the feature extractor, the observation range
// and the checks every observation must pass (a plugin's output like any external one), with the
// default noise where an observation brings none. Also tells a repeat of the previous scan.
#pragma once

#include <memory>
#include <vector>

#include <Eigen/Core>

#include "ekf_slam/core/feature_extraction/feature_extractor.h"
#include "ekf_slam/core/feature_extraction/scan_filter_chain.h"
#include "ekf_slam/core/filter/observation.h"
#include "ekf_slam/core/pipeline/pipeline_config.h"
#include "ekf_slam/core/pipeline/scan_report.h"

namespace ekf_slam {

class ObservationBuilder {
 public:
  ObservationBuilder(const PipelineConfig& config, PipelineCounters& counters);

  /// The extractor (configured already); null restores the default (TreeExtractor with
  /// config.extractor).
  void setExtractor(std::shared_ptr<FeatureExtractor> extractor);
  const FeatureExtractor& extractor() const { return *extractor_; }
  void setScanFilter(ScanFilterChain chain) { scan_filter_ = std::move(chain); }
  const ScanFilterChain& scanFilter() const { return scan_filter_; }

  /// The scan as the extractor sees it (after the filter chain). Throws ScanFormatError, before
  /// anything changes, for a scan the extractor or a filter cannot use at all.
  const LaserScanData& filtered(const LaserScanData& input, const Eigen::Vector3d& sensor_offset);
  /// True (counted) when `input` repeats the previous scan (stamp, angles, ranges): a duplicated
  /// message would count every feature twice. Otherwise it becomes the previous scan.
  bool repeats(double stamp, const LaserScanData& input);
  /// Forgets the previous scan.
  void reset();

  /// The observations of a filtered scan, within the observation range, checked; false for an
  /// unusable scan (no beams, no valid beam, no geometry: a sensor fault, not "nothing seen").
  bool extract(const LaserScanData& scan, std::vector<Observation>* observations,
               ScanReport* report);
  /// External observations, checked, the default noise where R is all zeros;
  /// report->input_index gets the index of each one kept.
  std::vector<Observation> check(std::vector<Observation> observations, ScanReport* report);

 private:
  const PipelineConfig& config_;
  PipelineCounters& counters_;
  std::shared_ptr<FeatureExtractor> extractor_;
  ScanFilterChain scan_filter_;
  LaserScanData filtered_scan_;  // workspace of the filter chain
  // The previous scan, to recognise a repeat of it.
  double last_scan_stamp_ = std::numeric_limits<double>::quiet_NaN();
  double last_scan_angle_min_ = 0.0, last_scan_angle_increment_ = 0.0;
  std::vector<float> last_scan_ranges_;
};

}  // namespace ekf_slam
