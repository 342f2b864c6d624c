// DJNN extension "landmark spacing" (landmark_spacing; docs/djnn.md, "The other failing
// seeds"): two landmarks are never closer than this. An observation whose source lies, with
// probability individual_probability, within that distance of a candidate landmark is that
// landmark or clutter, never another landmark: in the joint decision its "not in the map" is
// charged at the clutter density alone, and it is never admitted as a new landmark (a pose made
// over-confident by a large correction would otherwise duplicate the landmark).
#pragma once

#include <vector>

#include "ekf_slam/core/association/association_context.h"
#include "ekf_slam/core/common/parameters.h"

namespace ekf_slam {

class LandmarkSpacing {
 public:
  struct Params {
    double landmark_spacing = 0.0;  ///< [m]; 0: off (needs clutter_density > 0)
  };
  void read(const ParameterReader& r, double clutter_density);
  const Params& params() const { return p_; }
  bool on() const { return p_.landmark_spacing > 0.0; }
  /// Whether the source of `obs` lies, with probability of the gate `gate` (chi2(2)), within
  /// landmark_spacing of one of `landmarks` (state-order indices). False when off.
  bool within(const AssociationContext& ctx, int obs, const std::vector<int>& landmarks,
              double gate) const;

 private:
  Params p_;
};

}  // namespace ekf_slam
