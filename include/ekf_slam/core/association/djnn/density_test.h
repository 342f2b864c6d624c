// DJNN extension "density test" (landmark_density; docs/djnn.md): an observation paired with
// landmark j has likelihood N(v; 0, S) under that pairing, and lambda (per m^2) under "a landmark
// not in the map, or clutter" (lambda = landmark_density + clutter_density). NN's gate only asks
// v^T S^-1 v <= chi2: when the pose is uncertain by a metre, S is large, N(v; 0, S) falls below
// the density of unmapped landmarks, and a landmark never seen before is paired with an old one
// inside the wide gate. Jointly, observations that fit one pose correction multiply densities of
// the observation noise, far above lambda^k; a lone pairing does not. Each pairing is judged
// given the others, and withdrawn, least likely first, until the rest beat lambda.
// A user does not know the landmark density: with estimate_landmark_density it is estimated
// online from the map, as the mapped landmarks inside the sensor region per m^2 of that region,
// over the scans whose region holds any (a place seen before), so no one configures it.
#pragma once

#include "ekf_slam/core/association/djnn/djnn_paper.h"
#include "ekf_slam/core/association/djnn/local_scan.h"
#include "ekf_slam/core/common/parameters.h"

namespace ekf_slam {

class DensityTest {
 public:
  struct Params {
    double landmark_density = 0.0;  ///< unmapped landmarks per m^2 where the sensor looks; 0: off
    /// With landmark_density 0: estimate it online from the map (the test is off until the
    /// sensor region has held a mapped landmark).
    bool estimate_landmark_density = true;
    /// Withdraw, outside loop closures, the pairings that do not beat the density (the joint
    /// decision at loop closures weighs the density either way). Default: on when
    /// landmark_density is given (missed-detection profile: on).
    bool density_test = false;
  };
  void read(const ParameterReader& r);
  /// The sensor region whose area the estimate divides by.
  void configure(const SensorModel& sensor);
  void reset();
  const Params& params() const { return p_; }
  /// Parameters read elsewhere (DJNN switching to the missed-detection profile mid-run).
  void setParams(const Params& p) { p_ = p; }
  bool estimating() const { return p_.landmark_density <= 0.0 && p_.estimate_landmark_density; }
  /// The density in use: the configured one, or the estimate (0 before any).
  double density() const;
  /// The test of apply() runs.
  bool on() const { return p_.density_test && density() > 0.0; }
  /// Feeds the estimate with this scan's local region (after DjnnPaper::localRegion).
  void observe(const AssociationContext& ctx, const DjnnPaper& paper, const LocalScan& scan);
  /// The sensor region's area [m^2].
  double regionArea() const { return region_area_; }
  /// Withdraws the pairings that do not beat "not in the map", -2 ln of a density per m^2
  /// (`null_cost`; each observation's in its measurement space: unmappedCostAt).
  void apply(const AssociationContext& ctx, double null_cost, LocalScan* scan,
             DjnnStats* stats) const;

 private:
  Params p_;
  double region_area_ = 0.0;  ///< [m^2]
  double landmarks_seen_ = 0.0, area_seen_ = 0.0;
};

}  // namespace ekf_slam
