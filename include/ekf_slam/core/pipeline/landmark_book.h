// Per-landmark bookkeeping next to the filter: how often each landmark was paired, its mean
// descriptor (e.g. trunk diameter), when it was made, and so which landmarks are recent (made
// so lately that they may come from a pose now in doubt; docs/relocalisation.md).
#pragma once

#include <cstdint>
#include <limits>
#include <unordered_map>
#include <vector>

#include "ekf_slam/core/filter/ekf_slam.h"
#include "ekf_slam/core/pipeline/pipeline_config.h"
#include "ekf_slam/core/relocalisation/relocaliser.h"  // MapLandmark

namespace ekf_slam {

/// Per-landmark bookkeeping next to the EKF.
struct LandmarkInfo {
  double diameter = std::numeric_limits<double>::quiet_NaN();  ///< running mean descriptor
  std::uint32_t times_observed = 0;                            ///< scans it was paired in
  int descriptor_count = 0;
  std::int64_t created_scan = -1;         ///< scan that initialised it; -1: loaded from a map file
  std::int64_t created_informative = -1;  ///< informative scans before it (lost_recent_informative)
};

class LandmarkBook {
 public:
  explicit LandmarkBook(const PipelineConfig& config) : config_(config) {}

  /// A default LandmarkInfo for an unknown id.
  const LandmarkInfo& info(LandmarkId id) const;
  /// Paired in this scan, with this observation's descriptor (NaN: none).
  void paired(LandmarkId id, double descriptor);
  /// Made from an observation of scan `scan`.
  void created(LandmarkId id, double descriptor, std::uint32_t scan);
  /// Loaded from a map file.
  void loaded(LandmarkId id, const LandmarkInfo& info) { info_[id] = info; }
  void erase(LandmarkId id) { info_.erase(id); }
  void clear() { info_.clear(); }
  /// Every landmark's entry (a checkpoint's copy).
  const std::unordered_map<LandmarkId, LandmarkInfo>& entries() const { return info_; }

  /// A tracked scan with at least lost_min_observations observations (lost_recent_informative).
  void countScan(bool informative) { informative_scans_ += informative; }
  std::int64_t informativeScans() const { return informative_scans_; }
  void resetAge() { informative_scans_ = 0; }
  /// Created fewer than lost_recent_scans scans (of `scans` so far) ago; loaded ones never are.
  bool recent(LandmarkId id, std::uint32_t scans) const;

 private:
  const PipelineConfig& config_;
  std::unordered_map<LandmarkId, LandmarkInfo> info_;
  std::int64_t informative_scans_ = 0;
};

/// The map as a relocaliser takes it: ids, positions, marginal covariances, mean descriptors.
std::vector<MapLandmark> mapLandmarks(const EkfSlam& filter, const LandmarkBook& book);

}  // namespace ekf_slam
