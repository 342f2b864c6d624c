// Retro-reflective beacon extraction from intensities (docs/feature_extraction.md).
#include "ekf_slam/core/feature_extraction/beacon_extractor.h"

#include <algorithm>
#include <cmath>

namespace ekf_slam {

namespace {

void validate(const BeaconExtractorParams& p) {
  requireParameter(std::isfinite(p.intensity_threshold), "intensity_threshold", "must be finite",
                   p.intensity_threshold);
  requireParameter(p.max_gap >= 0, "max_gap", "must be >= 0", p.max_gap);
  requireParameter(p.min_width >= 0.0 && p.min_width < p.max_width, "min_width",
                   "must be >= 0 and < max_width", p.min_width);
  requireParameter(p.max_range > 0.0, "max_range", "must be > 0", p.max_range);
  requireParameter(p.range_jump > 0.0, "range_jump", "must be > 0", p.range_jump);
  requireParameter(p.beacon_radius >= 0.0, "beacon_radius", "must be >= 0", p.beacon_radius);
  requireParameter(p.sigma_range > 0.0, "sigma_range", "must be > 0", p.sigma_range);
  requireParameter(p.sigma_bearing > 0.0, "sigma_bearing", "must be > 0", p.sigma_bearing);
  if (p.centre != "geometric" && p.centre != "intensity") {
    throw ParameterError("parameter centre: must be one of {geometric, intensity}, got '" +
                         p.centre + "'");
  }
}

}  // namespace

BeaconExtractor::BeaconExtractor(const BeaconExtractorParams& p) : p_(p) { validate(p_); }

void BeaconExtractor::configure(const ParameterSource& params) {
  const ParameterReader r(params);
  BeaconExtractorParams p;
  p.intensity_threshold = r.number("intensity_threshold", p.intensity_threshold);
  p.max_gap = r.integer("max_gap", p.max_gap, 0, 1000);
  p.min_width = r.nonNegative("min_width", p.min_width);
  p.max_width = r.positive("max_width", p.max_width);
  if (!(p.min_width < p.max_width)) r.fail("min_width", "must be < max_width");
  p.max_range = r.positive("max_range", p.max_range);
  p.range_jump = r.positive("range_jump", p.range_jump);
  p.beacon_radius = r.nonNegative("beacon_radius", p.beacon_radius);
  p.centre = r.text("centre", p.centre, {"geometric", "intensity"});
  p.sigma_range = r.positive("sigma_range", p.sigma_range);
  p.sigma_bearing = r.positive("sigma_bearing", p.sigma_bearing);
  p_ = p;
}

void BeaconExtractor::checkScan(const LaserScanData& scan) const {
  const std::string problem = intensityProblem(scan);
  if (!problem.empty()) throw ScanFormatError("BeaconExtractor needs intensities: " + problem);
}

std::vector<DetectedBeacon> BeaconExtractor::detect(const LaserScanData& scan) const {
  std::vector<DetectedBeacon> out;
  const int n = static_cast<int>(scan.ranges.size());
  if (n == 0 || scan.intensities.size() != scan.ranges.size() || !std::isfinite(scan.angle_min) ||
      !std::isfinite(scan.angle_increment)) {
    return out;
  }
  const double max_range = std::min(p_.max_range, scan.range_max);
  const auto reflective = [&](int i) {
    const float r = scan.ranges[i];
    return std::isfinite(r) && r > 0.0f && r >= scan.range_min && r <= max_range &&
           scan.intensities[i] >= p_.intensity_threshold;
  };
  const double inc = scan.angle_increment;
  const bool weighted = p_.centre == "intensity";
  // Closes the group [first, last] (reflective beams only inside it are used).
  const auto close = [&](int first, int last) {
    double sx = 0.0, sy = 0.0, sw = 0.0, sr = 0.0;
    int count = 0;
    for (int i = first; i <= last; ++i) {
      if (!reflective(i)) continue;
      const double a = scan.angle_min + i * inc;
      const double w = weighted ? scan.intensities[i] : 1.0;
      sx += w * scan.ranges[i] * std::cos(a);
      sy += w * scan.ranges[i] * std::sin(a);
      sw += w;
      sr += scan.ranges[i];
      ++count;
    }
    if (!(sw > 0.0)) return;
    const double a0 = scan.angle_min + first * inc, a1 = scan.angle_min + last * inc;
    const double r0 = scan.ranges[first], r1 = scan.ranges[last];
    const double chord =
        std::hypot(r1 * std::cos(a1) - r0 * std::cos(a0), r1 * std::sin(a1) - r0 * std::sin(a0));
    // Each edge beam covers half a beam beyond its own direction.
    const double width = chord + (sr / count) * std::fabs(inc);
    if (width < p_.min_width || width > p_.max_width) return;
    DetectedBeacon b;
    b.range = std::hypot(sx / sw, sy / sw) + M_PI / 4.0 * p_.beacon_radius;
    b.bearing = std::atan2(sy / sw, sx / sw);
    b.width = width;
    b.first_beam = first;
    b.last_beam = last;
    out.push_back(b);
  };
  int first = -1, last = -1;
  for (int i = 0; i < n; ++i) {
    if (!reflective(i)) continue;
    const bool joins = first >= 0 && i - last - 1 <= p_.max_gap &&
                       std::fabs(scan.ranges[i] - scan.ranges[last]) <= p_.range_jump;
    if (!joins) {
      if (first >= 0) close(first, last);
      first = i;
    }
    last = i;
  }
  if (first >= 0) close(first, last);
  return out;
}

std::vector<Observation> BeaconExtractor::extract(const LaserScanData& scan) const {
  std::vector<Observation> out;
  const double beam_variance = scan.angle_increment * scan.angle_increment / 12.0;
  for (const DetectedBeacon& b : detect(scan)) {
    Observation o;
    o.z = Eigen::Vector2d(b.range, b.bearing);
    // Range: the laser's noise plus the depth of the centre behind the group, uncertain over a
    // quarter of its width. Bearing: the laser's noise plus the edges' one-beam quantisation.
    o.R = Eigen::Vector2d(p_.sigma_range * p_.sigma_range + b.width * b.width / 48.0,
                          p_.sigma_bearing * p_.sigma_bearing + beam_variance)
              .asDiagonal();
    o.descriptor = b.width;
    out.push_back(o);
  }
  return out;
}

}  // namespace ekf_slam
