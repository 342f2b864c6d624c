#include "ekf_slam/core/relocalisation/fgcbb.h"

namespace ekf_slam {

namespace {

GeometricConstraintParams fgcbbDefaults() {
  GeometricConstraintParams p;
  p.group_size = 6;  // the paper's N
  p.use_locality = true;
  return p;
}

}  // namespace

FGCBB::FGCBB() : GeometricConstraintBB(fgcbbDefaults()) {}

}  // namespace ekf_slam
