#include "ekf_slam/core/association/djnn/unmapped_returns.h"

#include <algorithm>

#include "ekf_slam/core/filter/observation_model.h"

namespace ekf_slam {

void UnmappedReturns::read(const ParameterReader& r) {
  p_.measure_unmapped_density =
      r.flag("measure_unmapped_density", Params().measure_unmapped_density);
}

void UnmappedReturns::configure(double region_area) {
  region_area_ = region_area;
  reset();
}

void UnmappedReturns::reset() { unpaired_ = area_ = 0.0; }

// A scan that pairs nothing is new ground, or a robot that has lost the map: neither says how
// much of what is in view is mapped.
void UnmappedReturns::observe(const AssociationContext& ctx, const LocalScan& scan,
                              double max_range) {
  if (!on()) return;
  int paired = 0, unpaired = 0;
  for (int i = 0; i < scan.observations(); ++i) {
    if (scan.assign[i] >= 0) {
      ++paired;
    } else {
      const Observation& o = ctx.observations()[i];
      unpaired += RangeBearingModel::range(o.z, o.kind) < max_range;
    }
  }
  if (paired == 0) return;
  unpaired_ += unpaired;
  area_ += region_area_;
}

double UnmappedReturns::density(double prior) const {
  if (!on()) return prior;
  // Until many regions are counted the prior dominates: one region's worth of it.
  const double measured = (unpaired_ + prior * region_area_) / (area_ + region_area_);
  return std::min(measured, prior);
}

}  // namespace ekf_slam
