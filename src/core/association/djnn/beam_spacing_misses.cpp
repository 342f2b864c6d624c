#include "ekf_slam/core/association/djnn/beam_spacing_misses.h"

#include "ekf_slam/core/filter/ekf_slam.h"

namespace ekf_slam {

void BeamSpacingMisses::read(const ParameterReader& r) {
  p_.beam_spacing_misses = r.flag("beam_spacing_misses", Params().beam_spacing_misses);
}

double BeamSpacingMisses::detectable(const AssociationContext& ctx, double range) const {
  const ScanOcclusion* scan = ctx.occlusion();
  return on() && scan != nullptr ? scan->hitProbability(range) : 1.0;
}

void BeamSpacingMisses::mark(const AssociationContext& ctx, LocalScan* scan) const {
  scan->detectable.clear();
  const ScanOcclusion* occlusion = ctx.occlusion();
  if (!on() || occlusion == nullptr) return;
  const int n = scan->candidates();
  scan->detectable.resize(n);
  for (int k = 0; k < n; ++k) {
    const Eigen::Vector2d d = ctx.ekf().landmark(scan->cand[k]) - scan->sensor_pose.head<2>();
    scan->detectable[k] = occlusion->hitProbability(d.norm());
  }
}

}  // namespace ekf_slam
