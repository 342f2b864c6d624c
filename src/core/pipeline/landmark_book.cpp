#include "ekf_slam/core/pipeline/landmark_book.h"

#include <cmath>

namespace ekf_slam {

const LandmarkInfo& LandmarkBook::info(LandmarkId id) const {
  static const LandmarkInfo kUnknown;
  const auto it = info_.find(id);
  return it == info_.end() ? kUnknown : it->second;
}

void LandmarkBook::paired(LandmarkId id, double descriptor) {
  LandmarkInfo& info = info_[id];
  ++info.times_observed;
  if (std::isfinite(descriptor)) {
    ++info.descriptor_count;
    info.diameter = info.descriptor_count == 1
                        ? descriptor
                        : info.diameter + (descriptor - info.diameter) / info.descriptor_count;
  }
}

void LandmarkBook::created(LandmarkId id, double descriptor, std::uint32_t scan) {
  LandmarkInfo& info = info_[id];
  info.times_observed = 1;
  info.created_scan = scan;
  info.created_informative = informative_scans_;
  if (std::isfinite(descriptor)) {
    info.diameter = descriptor;
    info.descriptor_count = 1;
  }
}

bool LandmarkBook::recent(LandmarkId id, std::uint32_t scans) const {
  const auto it = info_.find(id);
  if (it == info_.end() || it->second.created_scan < 0) return false;
  if (config_.lost_recent_informative)
    return informative_scans_ - it->second.created_informative <= config_.lost_recent_scans;
  return static_cast<std::int64_t>(scans) - it->second.created_scan <= config_.lost_recent_scans;
}

std::vector<MapLandmark> mapLandmarks(const EkfSlam& filter, const LandmarkBook& book) {
  std::vector<MapLandmark> map(filter.numLandmarks());
  for (std::size_t k = 0; k < map.size(); ++k) {
    MapLandmark& l = map[k];
    l.id = filter.landmarkIds()[k];
    l.position = filter.landmark(static_cast<int>(k));
    l.covariance = filter.landmarkCovariance(static_cast<int>(k));
    l.descriptor = book.info(l.id).diameter;
  }
  return map;
}

}  // namespace ekf_slam
