// The "ekf_slam/TreeExtractor" plugin: ACFR's trunk detector
// (core/feature_extraction/tree_extractor.h, unchanged) behind the FeatureExtractor interface.
// Observations carry the trunk diameter as descriptor and a zero R, i.e. the pipeline's sigma_range
// / sigma_bearing, as before the interface existed.
#pragma once

#include <string>
#include <vector>

#include "ekf_slam/core/feature_extraction/feature_extractor.h"
#include "ekf_slam/core/feature_extraction/tree_extractor.h"

namespace ekf_slam {

class TreeFeatureExtractor : public FeatureExtractor {
 public:
  explicit TreeFeatureExtractor(const TreeExtractorParams& p = TreeExtractorParams())
      : detector_(p) {}

  /// Parameter names are TreeExtractorParams' fields (max_range, range_jump, ...; angles in rad).
  void configure(const ParameterSource& params) override;
  std::string name() const override { return "TreeExtractor"; }
  /// Half the widest trunk segment kept (max_extent).
  double featureRadius() const override { return 0.5 * detector_.params().max_extent; }
  std::vector<Observation> extract(const LaserScanData& scan) const override;

  const TreeExtractor& detector() const { return detector_; }

 private:
  TreeExtractor detector_;
};

/// Reads TreeExtractorParams under the names `prefix + field` (the pipeline's legacy top-level
/// names use prefix "extractor_", the plugin's own section none), defaults from `defaults`.
TreeExtractorParams readTreeExtractorParams(const ParameterSource& params,
                                            const std::string& prefix,
                                            const TreeExtractorParams& defaults);

}  // namespace ekf_slam
