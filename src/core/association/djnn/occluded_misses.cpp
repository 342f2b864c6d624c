#include "ekf_slam/core/association/djnn/occluded_misses.h"

#include <cmath>

#include "ekf_slam/core/common/chi2.h"

namespace ekf_slam {

void OccludedMisses::read(const ParameterReader& r, double individual_probability) {
  p_.occlusion_aware_misses = r.flag("occlusion_aware_misses", Params().occlusion_aware_misses);
  sigmas_ = std::sqrt(chi2Quantile(individual_probability, 1));
}

void OccludedMisses::mark(const AssociationContext& ctx, LocalScan* scan) const {
  const int n = scan->candidates();
  scan->hidden.assign(n, 0);
  const ScanOcclusion* occlusion = ctx.occlusion();
  if (!on() || occlusion == nullptr) return;
  for (int k = 0; k < n; ++k) {
    if (scan->count[k] > 0) continue;  // paired: seen, whatever the scan says
    const int j = scan->cand[k];
    const Eigen::Vector2d z = ctx.prediction(j, MeasurementKind::kRangeBearing).z_hat;
    const Eigen::Matrix2d S = ctx.predictedCovariance(j);
    scan->hidden[k] = occlusion->occluded(z(0), z(1), S(0, 0), S(1, 1), sigmas_);
  }
}

}  // namespace ekf_slam
