// DJNN extension "detection probability estimated online" (detection_probability not set;
// docs/djnn.md, "P_D estimated online"). A camera's datasheet rarely states how often a marker in
// view is detected, and DJNN left at P_D = 1 with a sensor that misses a third of its landmarks
// drops its tentative features and removes its landmarks on misses, with the missed-detection
// profile off: `fiducials` with the line left out closed 12 of 20 runs wrongly. When the user sets
// no value, DJNN starts as with P_D = 1 and counts what its evidence counter sees: over every
// scan, the map's landmarks in the penalty region (not hidden, the scan not held) are looks,
// weighted by the share of P_D the beams give them (BeamSpacingMisses), and those paired are hits.
// Once the hit rate is below detection_switch_level with 99 % confidence, the sensor misses
// landmarks: DJNN takes the missed-detection profile's defaults (under the user's values, as a
// stated P_D < 1 would) and counts evidence with the estimate, brought up to date every scan. A
// sensor that sees what it should never gets there, and DJNN stays exactly as with P_D = 1.
#pragma once

#include <string>

#include "ekf_slam/core/association/association_context.h"
#include "ekf_slam/core/association/djnn/djnn_paper.h"
#include "ekf_slam/core/association/djnn/local_scan.h"
#include "ekf_slam/core/common/parameters.h"

namespace ekf_slam {

/// The exact one-sided upper confidence bound (Clopper-Pearson) of a success rate seen as `hits`
/// of `looks` trials (both may be fractional: looks weighted by a detectable share); 1 with no
/// looks or no misses.
double binomialUpperBound(double hits, double looks, double confidence);

class DetectionEstimate {
 public:
  struct Params {
    /// The hit rate below which (with 99 % confidence) the sensor is taken to miss landmarks.
    double detection_switch_level = 0.8;
  };
  void read(const ParameterReader& r);
  const Params& params() const { return p_; }
  /// On when detection_probability was not set and the missed-detection profile is allowed.
  void configure(bool on);
  void reset();
  bool on() const { return on_; }
  /// The profile is on: the estimate is in use.
  bool switched() const { return switched_; }

  /// This scan's looks at the map's landmarks (after the bias test's withdrawals in `result`,
  /// before the paper's evidence step). True at the scan where the sensor is found to miss
  /// landmarks (once).
  bool observe(const AssociationContext& ctx, const DjnnPaper& paper, const LocalScan& scan,
               const AssociationResult& result);
  /// Hits per look so far (1 before any look).
  double estimate() const { return looks_ > 0.0 ? hits_ / looks_ : 1.0; }
  /// The one-sided 99 % upper confidence bound of the hit rate (binomialUpperBound).
  double upperBound() const;
  double looks() const { return looks_; }
  /// What to tell the user at the switch.
  std::string notice() const;

 private:
  Params p_;
  bool on_ = false;
  bool switched_ = false;
  double looks_ = 0.0, hits_ = 0.0;
};

}  // namespace ekf_slam
