// DJNN extension "measured unmapped density" (measure_unmapped_density; docs/djnn.md): the joint
// decision at loop closures weighs every pairing against "not in the map", a density per m^2 of
// returns from no mapped landmark. The landmark density (DensityTest's estimate: mapped landmarks
// per m^2 of the sensor region) plus clutter is that density on new ground. At a revisit most
// landmarks in view are mapped already, and it overstates what is left unmapped: in Victoria
// Park by 18 times, enough to close its loops with pairings the right units of the null no
// longer carry. This part measures the density where the map is: the returns left unpaired in
// the scans decided outside a closure that paired at least one, per m^2 of the sensor region
// over those scans, shrunk toward the prior with the weight of one region. It can only lower the
// null's density: above the landmark density plus clutter (returns of landmarks still waiting
// for admission, at a sensor that misses them) it keeps that bound, the density of all landmarks.
#pragma once

#include "ekf_slam/core/association/association_context.h"
#include "ekf_slam/core/association/djnn/local_scan.h"
#include "ekf_slam/core/common/parameters.h"

namespace ekf_slam {

class UnmappedReturns {
 public:
  struct Params {
    bool measure_unmapped_density = true;
  };
  void read(const ParameterReader& r);
  /// The sensor region's area [m^2] (DensityTest::regionArea()).
  void configure(double region_area);
  void reset();
  const Params& params() const { return p_; }
  bool on() const { return p_.measure_unmapped_density && region_area_ > 0.0; }
  /// Counts a scan decided outside a loop closure: if it paired any observation, its
  /// observations within `max_range` left unpaired and the region's area.
  void observe(const AssociationContext& ctx, const LocalScan& scan, double max_range);
  /// The density of "not in the map" per m^2: the measured one, no more than `prior` (the
  /// landmark density plus clutter), or `prior` itself when off.
  double density(double prior) const;

 private:
  Params p_;
  double region_area_ = 0.0;  ///< [m^2]
  double unpaired_ = 0.0;     ///< returns counted
  double area_ = 0.0;         ///< [m^2] over the scans counted
};

}  // namespace ekf_slam
