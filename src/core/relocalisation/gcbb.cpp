#include "ekf_slam/core/relocalisation/gcbb.h"

namespace ekf_slam {

namespace {

GeometricConstraintParams gcbbDefaults() {
  GeometricConstraintParams p;
  p.group_size = 0;  // one group: every observation in one tree
  p.use_locality = false;
  return p;
}

}  // namespace

GCBB::GCBB() : GeometricConstraintBB(gcbbDefaults()) {}

}  // namespace ekf_slam
