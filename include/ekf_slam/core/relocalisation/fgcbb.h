// FGCBB, fast geometric-constraint branch and bound (seed 001 paper 2, section 3): GCBB with the
// observations split into compact groups of at most N (group_size, default 6), which makes the
// search linear in the number of observations, and map pairs restricted to C_ij = 1 (closer than
// the sensor range R), which lets candidates come from a landmark's precomputed neighbours.
// The search is GeometricConstraintBB's.
#pragma once

#include <string>

#include "ekf_slam/core/relocalisation/geometric_constraint_bb.h"

namespace ekf_slam {

class FGCBB : public GeometricConstraintBB {
 public:
  FGCBB();
  std::string name() const override { return "FGCBB"; }
};

}  // namespace ekf_slam
