// GCBB, geometric-constraint branch and bound (seed 001 paper 2, section 2; the baseline FGCBB is
// timed against): every observation in one interpretation tree, every landmark a candidate,
// no locality test. The search is GeometricConstraintBB's.
#pragma once

#include <string>

#include "ekf_slam/core/relocalisation/geometric_constraint_bb.h"

namespace ekf_slam {

class GCBB : public GeometricConstraintBB {
 public:
  GCBB();
  std::string name() const override { return "GCBB"; }
};

}  // namespace ekf_slam
