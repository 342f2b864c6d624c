#include "ekf_slam/core/relocalisation/relocaliser.h"

namespace ekf_slam {

const char* toString(RelocalisationStatus s) {
  switch (s) {
    case RelocalisationStatus::kFound:
      return "found";
    case RelocalisationStatus::kNotFound:
      return "not_found";
    case RelocalisationStatus::kAmbiguous:
      return "ambiguous";
  }
  return "unknown";
}

RelocalisationResult Relocaliser::relocaliseWindow(const std::vector<CarriedScan>& scans,
                                                   const Eigen::Vector3d& sensor_offset,
                                                   const PosePrior* prior) {
  if (scans.empty()) return relocalise({}, sensor_offset, prior);
  RelocalisationResult r = relocalise(scans.back().observations, sensor_offset, prior);
  std::size_t older = 0;
  for (std::size_t s = 0; s + 1 < scans.size(); ++s) older += scans[s].observations.size();
  r.landmark.insert(r.landmark.begin(), older, kNoLandmark);
  return r;
}

}  // namespace ekf_slam
