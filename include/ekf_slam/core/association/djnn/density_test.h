// DJNN extension "density test" (landmark_density; docs/djnn.md): an observation paired with
// landmark j has likelihood N(v; 0, S) under that pairing, and lambda (per m^2) under "a landmark
// not in the map, or clutter" (lambda = landmark_density + clutter_density). NN's gate only asks
// v^T S^-1 v <= chi2: when the pose is uncertain by a metre, S is large, N(v; 0, S) falls below
// the density of unmapped landmarks, and a landmark never seen before is paired with an old one
// inside the wide gate. Jointly, observations that fit one pose correction multiply densities of
// the observation noise, far above lambda^k; a lone pairing does not. Each pairing is judged
// given the others, and withdrawn, least likely first, until the rest beat lambda.
#pragma once

#include "ekf_slam/core/association/djnn/djnn_paper.h"
#include "ekf_slam/core/association/djnn/local_scan.h"
#include "ekf_slam/core/common/parameters.h"

namespace ekf_slam {

class DensityTest {
 public:
  struct Params {
    double landmark_density = 0.0;  ///< unmapped landmarks per m^2 where the sensor looks; 0: off
  };
  void read(const ParameterReader& r);
  const Params& params() const { return p_; }
  bool on() const { return p_.landmark_density > 0.0; }
  /// -2 ln of "a landmark not in the map, or clutter" per observation (also the joint
  /// decision's "not in the map").
  double unmappedCost(double clutter_density) const;
  void apply(const AssociationContext& ctx, double clutter_density, LocalScan* scan,
             DjnnStats* stats) const;

 private:
  Params p_;
};

}  // namespace ekf_slam
