// The "ekf_slam/BeaconExtractor" plugin: retro-reflective beacons (tape on poles, reflectors)
// from a laser's intensity channel. Beams at or above an intensity threshold form groups
// (consecutive, allowing short gaps); a group of a plausible width is one beacon. Its centre is
// the mean of the group's end points (geometric, or weighted by intensity), pushed back along
// its bearing by pi/4 of the beacon radius (the mean depth of points spread evenly across a
// cylinder's visible width). Details and the noise model: docs/feature_extraction.md.
#pragma once

#include <algorithm>
#include <string>
#include <vector>

#include "ekf_slam/core/feature_extraction/feature_extractor.h"

namespace ekf_slam {

struct BeaconExtractorParams {
  double intensity_threshold = 1000.0;  ///< a beam is reflective at or above this
  int max_gap = 1;                      ///< dull beams allowed inside a group [beams]
  double min_width = 0.02;              ///< a group's width must lie in [min, max] [m]
  double max_width = 0.5;
  double max_range = 30.0;     ///< farther beams are ignored [m]
  double range_jump = 0.3;     ///< consecutive reflective beams further apart in range split [m]
  double beacon_radius = 0.0;  ///< 0: point reflectors; > 0: the centre is behind [m]
  std::string centre = "geometric";  ///< "geometric" or "intensity" (weighted mean)
  double sigma_range = 0.05;         ///< the laser's range noise [m]
  double sigma_bearing = 0.005;      ///< and bearing noise [rad]
};

/// One group of reflective beams accepted as a beacon (for tests and tools).
struct DetectedBeacon {
  double range;    ///< to the beacon's centre [m]
  double bearing;  ///< [rad], sensor frame
  double width;    ///< the group's width [m]
  int first_beam;
  int last_beam;
};

class BeaconExtractor : public FeatureExtractor {
 public:
  explicit BeaconExtractor(const BeaconExtractorParams& p = BeaconExtractorParams());

  void configure(const ParameterSource& params) override;
  std::string name() const override { return "BeaconExtractor"; }
  bool needsIntensities() const override { return true; }
  /// The pole's radius, or half the widest group kept (its hits lie within that of its centre).
  double featureRadius() const override { return std::max(p_.beacon_radius, 0.5 * p_.max_width); }
  /// The poles' radius (beacon_radius; 0, point reflectors: unknown).
  double thinnestFeatureRadius() const override { return p_.beacon_radius; }
  /// Throws ScanFormatError for a scan without (or with a wrong number of) intensities.
  void checkScan(const LaserScanData& scan) const override;
  /// Observations with R from the group (docs/feature_extraction.md), descriptor = width.
  std::vector<Observation> extract(const LaserScanData& scan) const override;

  /// The accepted groups themselves.
  std::vector<DetectedBeacon> detect(const LaserScanData& scan) const;
  const BeaconExtractorParams& params() const { return p_; }

 private:
  BeaconExtractorParams p_;
};

}  // namespace ekf_slam
