// Which points a laser scan could not have seen: a point is hidden when every beam that could
// have hit it returned clearly short of it (something nearer stood in the way). Built from the
// scan the features came from; an associator asks it before counting a landmark as missed
// (DJNN's occlusion_aware_misses, docs/djnn.md). ROS-free.
#pragma once

#include <cstddef>
#include <vector>

#include "ekf_slam/core/feature_extraction/feature_extractor.h"

namespace ekf_slam {

class ScanOcclusion {
 public:
  ScanOcclusion() = default;
  /// `feature_radius`: how far in front of a feature's reported position its own surface can
  /// return a beam (FeatureExtractor::featureRadius); `range_sigma`: std dev of one beam's range;
  /// `thinnest_radius`: the thinnest feature's radius (FeatureExtractor::thinnestFeatureRadius),
  /// 0 when unknown.
  ScanOcclusion(const LaserScanData& scan, double feature_radius, double range_sigma,
                double thinnest_radius = 0.0) {
    assign(scan, feature_radius, range_sigma, thinnest_radius);
  }
  /// The same, reusing the buffers (one per pipeline, refilled every scan).
  void assign(const LaserScanData& scan, double feature_radius, double range_sigma,
              double thinnest_radius = 0.0);

  /// True when a point at (range, bearing) in the sensor frame was hidden from the scan: every
  /// beam within sigmas * sqrt(bearing_var) plus the feature's angular radius of `bearing` (at
  /// least the two beams either side of it) returned a range shorter than range - radius -
  /// sigmas * sqrt(range_var + range_sigma^2). range_var and bearing_var are the predicted
  /// point's (H P H^T). A beam without a return (non-finite, <= 0, outside [range_min,
  /// range_max)) never hides; a bearing outside the scan, or bad input (NaN, negative
  /// variance), is not hidden: the caller then counts a miss as it would without this.
  bool occluded(double range, double bearing, double range_var, double bearing_var,
                double sigmas) const;

  /// The probability that at least one beam of the scan falls on the thinnest feature at `range`
  /// (beams at a uniformly random phase): the angle the feature spans over the beam spacing,
  /// at most 1. 1 when the feature's size is unknown (0), without a scan, or for bad input.
  double hitProbability(double range) const;

  std::size_t beams() const { return ranges_.size(); }
  double featureRadius() const { return feature_radius_; }

 private:
  std::vector<float> ranges_;
  double angle_min_ = 0.0;
  double angle_increment_ = 0.0;
  double range_min_ = 0.0;
  double range_max_ = 0.0;
  double feature_radius_ = 0.0;
  double thinnest_radius_ = 0.0;
  double range_var_ = 0.0;  // one beam's
};

}  // namespace ekf_slam
