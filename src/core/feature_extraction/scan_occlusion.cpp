#include "ekf_slam/core/feature_extraction/scan_occlusion.h"

#include <algorithm>
#include <cmath>

#include "ekf_slam/core/common/angles.h"

namespace ekf_slam {

void ScanOcclusion::assign(const LaserScanData& scan, double feature_radius, double range_sigma,
                           double thinnest_radius) {
  ranges_ = scan.ranges;
  angle_min_ = scan.angle_min;
  angle_increment_ = scan.angle_increment;
  range_min_ = scan.range_min;
  range_max_ = scan.range_max;
  // Bad values make every query "not hidden" below (the caller's behaviour without occlusion).
  feature_radius_ = std::isfinite(feature_radius) ? std::max(0.0, feature_radius) : 0.0;
  range_var_ = std::isfinite(range_sigma) ? range_sigma * range_sigma : 0.0;
  thinnest_radius_ = std::isfinite(thinnest_radius) ? std::max(0.0, thinnest_radius) : 0.0;
}

double ScanOcclusion::hitProbability(double range) const {
  const double spacing = std::fabs(angle_increment_);
  if (ranges_.empty() || !(thinnest_radius_ > 0.0) || !std::isfinite(spacing) || !(spacing > 0.0) ||
      !std::isfinite(range) || !(range > thinnest_radius_)) {
    return 1.0;
  }
  return std::min(1.0, 2.0 * std::asin(thinnest_radius_ / range) / spacing);
}

bool ScanOcclusion::occluded(double range, double bearing, double range_var, double bearing_var,
                             double sigmas) const {
  const std::size_t n = ranges_.size();
  if (n == 0 || !(angle_increment_ != 0.0) || !std::isfinite(angle_increment_) ||
      !std::isfinite(angle_min_)) {
    return false;
  }
  if (!std::isfinite(range) || !std::isfinite(bearing) || !(range > 0.0) || !(range_var >= 0.0) ||
      !(bearing_var >= 0.0) || !(sigmas >= 0.0) || !std::isfinite(range_var + bearing_var)) {
    return false;
  }
  // Nearer than this, a return cannot be the point's own surface or its range error.
  const double front = range - feature_radius_ - sigmas * std::sqrt(range_var + range_var_);
  if (!(front > 0.0)) return false;
  // Beams that could have hit it: its bearing error plus the angle its radius spans.
  const double half_width =
      sigmas * std::sqrt(bearing_var) + std::asin(std::min(1.0, feature_radius_ / range));
  // The bearing relative to the scan's middle beam, wrapped, so a full-turn scan works too.
  const double mid = angle_min_ + 0.5 * (n - 1) * angle_increment_;
  const double at =
      (0.5 * (n - 1) * angle_increment_ + wrapAngle(bearing - mid)) / angle_increment_;
  const double step = half_width / std::fabs(angle_increment_);
  const double lo = std::floor(at - step), hi = std::ceil(at + step);
  if (lo < 0.0 || hi > static_cast<double>(n - 1)) return false;  // partly outside the scan
  for (auto i = static_cast<std::size_t>(lo); i <= static_cast<std::size_t>(hi); ++i) {
    const double r = ranges_[i];
    const bool returned = std::isfinite(r) && r > 0.0 && r >= range_min_ && r < range_max_;
    if (!returned || r >= front) return false;  // this beam could have seen the point
  }
  return true;
}

}  // namespace ekf_slam
