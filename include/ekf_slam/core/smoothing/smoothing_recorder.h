// What the batch smoother needs from a SlamPipeline run, collected scan by scan: each scan's
// odometry and pairings, the pose the pipeline gave it, where each landmark was first placed; and
// the smoothing of it all at the end (docs/smoothing.md). ROS-free; the offline runner and
// bench_smoother use it.
#pragma once

#include <cstddef>
#include <unordered_map>
#include <vector>

#include <Eigen/Core>

#include "ekf_slam/core/pipeline/slam_pipeline.h"
#include "ekf_slam/core/smoothing/batch_smoother.h"

namespace ekf_slam {

class SmoothingRecorder {
 public:
  /// After each scan the pipeline processed (not a dropped duplicate), with the pipeline as it is
  /// after that scan. A relocalised scan's lost path replaces the poses of the scans it covers and
  /// drops their pairings (made at a pose the fix contradicts); the odometry into its first scan
  /// (or into the fix's scan) is not used: a real kidnap is not in the odometry.
  void add(const ScanReport& report, const SlamPipeline& pipeline);

  const std::vector<SmoothingScan>& scans() const { return scans_; }

  /// Smooths the run. Unknowns: every scan pose and every landmark the run created, the
  /// pipeline's final map first (its mapLandmarks(), in that order: the result's first
  /// landmarks), then the removed ones by id; marginal covariances for the final map's only
  /// (unless params asks for fewer).
  SmoothingResult smooth(const SlamPipeline& pipeline, SmootherParams params = {}) const;
  /// smooth()'s unknown landmarks with their starting positions, in its order.
  std::vector<SmoothingLandmark> landmarks(const SlamPipeline& pipeline) const;

  /// The prior variance of a scan the smoother takes no odometry into: keeps the system solvable,
  /// far too weak to pull the pose [m^2, rad^2].
  static constexpr double kUninformative = 1e6;

 private:
  std::vector<SmoothingScan> scans_;
  std::unordered_map<LandmarkId, Eigen::Vector2d> created_;  // first placement by id
};

}  // namespace ekf_slam
