// DJNN extension "beam-spacing misses" (beam_spacing_misses; docs/djnn.md): the paper's evidence
// step takes one detection probability P_D for every landmark. A laser's beams fan out, so a thin
// pole beyond the range where the beams are farther apart than its width falls between them in
// some scans: it is truly missed there, and the paper's -1 per miss removes it, or drops it while
// tentative with its sightings (`beacons`: 0.1 m poles at 25-30 m between 0.5 deg beams). With
// the thinnest feature's radius from the extractor's configuration (a pole's radius is on the
// user's drawing) this part gives each landmark and feature its own P_D: the stated P_D times the
// chance that a beam falls on it (ScanOcclusion::hitProbability), in both evidence steps, so the
// paper's units hold. Without a scan, or with the feature's size unknown, the share is 1.
#pragma once

#include "ekf_slam/core/association/association_context.h"
#include "ekf_slam/core/association/djnn/local_scan.h"
#include "ekf_slam/core/common/parameters.h"

namespace ekf_slam {

class BeamSpacingMisses {
 public:
  struct Params {
    bool beam_spacing_misses = true;
  };
  void read(const ParameterReader& r);
  const Params& params() const { return p_; }
  bool on() const { return p_.beam_spacing_misses; }
  /// The share of P_D the scan's beams give a feature at `range` from the sensor [m].
  double detectable(const AssociationContext& ctx, double range) const;
  /// scan->detectable, per candidate (empty when the share is 1 for every one).
  void mark(const AssociationContext& ctx, LocalScan* scan) const;

 private:
  Params p_;
};

}  // namespace ekf_slam
