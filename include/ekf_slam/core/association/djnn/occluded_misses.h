// DJNN extension "occlusion-aware misses" (occlusion_aware_misses; docs/djnn.md): the paper's
// counter scores -1 for every landmark in the sensor region left unpaired, also one that
// something nearer hid; it is then removed and created again when it comes back into sight
// (`beacons`: beacons behind parked cars). When the scan shows a nearer return at every beam
// that could have hit the landmark (ScanOcclusion, from the pipeline), the landmark was out of
// view, not missed: r_k = 0. Without a scan (point observations) nothing is hidden.
#pragma once

#include "ekf_slam/core/association/association_context.h"
#include "ekf_slam/core/association/djnn/local_scan.h"
#include "ekf_slam/core/common/parameters.h"

namespace ekf_slam {

class OccludedMisses {
 public:
  struct Params {
    bool occlusion_aware_misses = true;
  };
  /// `individual_probability`: the pairing gate's; the same probability bounds the landmark's
  /// range and bearing error here.
  void read(const ParameterReader& r, double individual_probability);
  const Params& params() const { return p_; }
  bool on() const { return p_.occlusion_aware_misses; }
  /// scan->hidden, per candidate: 1 for an unpaired landmark the scan hid.
  void mark(const AssociationContext& ctx, LocalScan* scan) const;

 private:
  Params p_;
  double sigmas_ = 0.0;
};

}  // namespace ekf_slam
