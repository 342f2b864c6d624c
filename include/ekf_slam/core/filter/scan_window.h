// A relocalisation window: the observations of the last few scans, carried into the current
// base_link by odometry (docs/relocalisation.md, "A window of scans"). Where one scan sees too few
// mapped landmarks to be recognised, two to four together may; each older observation's
// covariance grows by the odometry's uncertainty between its scan and the current one, so the
// relocaliser's joint tests stay honest.
#pragma once

#include <cstdint>
#include <deque>
#include <vector>

#include <Eigen/Core>

#include "ekf_slam/core/filter/observation.h"

namespace ekf_slam {

/// One scan of a window: its observations as seen (its own sensor frame), and where its base_link
/// lies in the current base_link by odometry, with that relative pose's covariance.
struct CarriedScan {
  std::uint32_t scan = 0;  ///< the pipeline's scan index
  std::vector<Observation> observations;
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();
  Eigen::Matrix3d origin_covariance = Eigen::Matrix3d::Zero();
  /// The scan's own pose estimate (map frame) and Q, the current pose's covariance given it (the
  /// odometry's noise since).
  Eigen::Vector3d pose = Eigen::Vector3d::Zero();
  Eigen::Matrix3d Q = Eigen::Matrix3d::Zero();
};

/// Carries a point on an older base_link (and its covariance) into the current base_link, where
/// that base_link lies at `origin` with covariance `origin_covariance` (first order).
void carryPoint(const Eigen::Vector3d& origin, const Eigen::Matrix3d& origin_covariance,
                Eigen::Vector2d* point, Eigen::Matrix2d* covariance);

/// The last `size` scans with observations, seen while the pipeline is lost (the estimate is
/// then pure dead reckoning, so the difference of two estimates is the odometry between them).
class ScanWindow {
 public:
  explicit ScanWindow(int size = 1) : size_(size) {}
  int size() const { return size_; }
  void clear() { scans_.clear(); }
  bool empty() const { return scans_.empty(); }
  /// Odometry since the last call: pose' = f(pose), F = df/dpose, Q its noise (map frame).
  /// Every stored scan's relative-pose uncertainty grows by it.
  void addMotion(const Eigen::Matrix3d& F, const Eigen::Matrix3d& Q);
  /// A scan at the (dead-reckoned) estimate `pose`; one without observations is not stored. The
  /// oldest beyond `size` scans are dropped.
  void push(std::uint32_t scan, const Eigen::Vector3d& pose,
            const std::vector<Observation>& observations);
  /// The stored scans, oldest first, carried into the base_link at `now` (the current estimate,
  /// after the last addMotion).
  std::vector<CarriedScan> carried(const Eigen::Vector3d& now) const;

 private:
  struct Entry {
    std::uint32_t scan;
    Eigen::Vector3d pose;
    Eigen::Matrix3d Q;  // covariance of the current pose given this one's (map frame)
    std::vector<Observation> observations;
  };
  int size_;
  std::deque<Entry> scans_;
};

}  // namespace ekf_slam
