#include "ekf_slam/core/feature_extraction/tree_feature_extractor.h"

namespace ekf_slam {

TreeExtractorParams readTreeExtractorParams(const ParameterSource& params,
                                            const std::string& prefix,
                                            const TreeExtractorParams& defaults) {
  const ParameterReader r(params);
  const auto n = [&prefix](const char* field) { return prefix + field; };
  TreeExtractorParams e = defaults;
  e.max_range = r.positive(n("max_range"), e.max_range);
  e.range_jump = r.positive(n("range_jump"), e.range_jump);
  e.angle_gap = r.positive(n("angle_gap"), e.angle_gap);
  e.occlusion_distance = r.nonNegative(n("occlusion_distance"), e.occlusion_distance);
  e.occlusion_lookahead = r.integer(n("occlusion_lookahead"), e.occlusion_lookahead, 0, 1000);
  e.neighbour_angle = r.nonNegative(n("neighbour_angle"), e.neighbour_angle);
  e.max_extent = r.positive(n("max_extent"), e.max_extent);
  e.min_range = r.nonNegative(n("min_range"), e.min_range);
  e.edge_margin = r.nonNegative(n("edge_margin"), e.edge_margin);
  e.max_range_difference_divisor =
      r.positive(n("max_range_difference_divisor"), e.max_range_difference_divisor);
  e.range_resolution = r.nonNegative(n("range_resolution"), e.range_resolution);
  return e;
}

void TreeFeatureExtractor::configure(const ParameterSource& params) {
  detector_ = TreeExtractor(readTreeExtractorParams(params, "", TreeExtractorParams()));
}

std::vector<Observation> TreeFeatureExtractor::extract(const LaserScanData& scan) const {
  std::vector<Observation> out;
  for (const DetectedTree& t :
       detector_.extract(scan.ranges, scan.angle_min, scan.angle_increment)) {
    Observation o;
    o.z = Eigen::Vector2d(t.range, t.bearing);
    o.R.setZero();  // the pipeline's default noise, as before the plugin interface
    o.descriptor = t.diameter;
    out.push_back(o);
  }
  return out;
}

}  // namespace ekf_slam
