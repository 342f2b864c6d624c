// The geometry FGCBB and GCBB share (seed 001 paper 2, section 2.1; ALGORITHMS.md section 6):
// observations as points on base_link with their covariance, the unary (descriptor) and binary
// (pairwise distance) constraints with their chi-square gates, a static grid over the map with
// the locality table C_ij, and the pose from a set of pairings (closed-form 2D alignment refined
// by weighted Gauss-Newton, with its covariance and the joint Mahalanobis distance).
#pragma once

#include <cstdint>
#include <limits>
#include <unordered_map>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "ekf_slam/core/common/pose2d.h"
#include "ekf_slam/core/relocalisation/relocaliser.h"

namespace ekf_slam {

/// One observation as a point on base_link.
struct ObservedPoint {
  int input = 0;                                  ///< index of the observation in the scan
  Eigen::Vector2d p = Eigen::Vector2d::Zero();    ///< position on base_link [m]
  Eigen::Matrix2d cov = Eigen::Matrix2d::Zero();  ///< from R through the polar Jacobian
  double range = 0.0;                             ///< from the sensor [m]
  double descriptor = std::numeric_limits<double>::quiet_NaN();
};

/// Converts a scan's observations to base_link points. Observations that are not finite, have
/// a non-positive-definite R, or lie farther than `max_range` from the sensor are dropped.
std::vector<ObservedPoint> observedPoints(const std::vector<Observation>& observations,
                                          const Eigen::Vector3d& sensor_offset, double max_range);

/// Unary constraint: (d_obs - d_map)^2 <= gate * variance. Always true when either descriptor is
/// NaN (unknown descriptors do not constrain).
bool unaryCompatible(double d_obs, double d_map, double variance, double gate);

/// Binary constraint statistic: the squared difference between the observed distance |a - b| and
/// the map distance |ma - mb| over the sum of their variances (each distance's variance through
/// its gradient; the two landmarks taken as uncorrelated, which over-estimates the variance
/// since map errors are positively correlated). Compared with chi2(1).
double binaryStatistic(const Eigen::Vector2d& a, const Eigen::Matrix2d& cov_a,
                       const Eigen::Vector2d& b, const Eigen::Matrix2d& cov_b,
                       const Eigen::Vector2d& ma, const Eigen::Matrix2d& cov_ma,
                       const Eigen::Vector2d& mb, const Eigen::Matrix2d& cov_mb);

/// The map, a uniform grid over it and the locality table: for each landmark the landmarks
/// closer than `radius` (C_ij = 1), built once per map in O(n * neighbours).
class MapPairTable {
 public:
  /// Landmarks with a non-finite position or a covariance that is not finite are skipped.
  void build(const std::vector<MapLandmark>& map, double radius);

  const std::vector<MapLandmark>& landmarks() const { return landmarks_; }
  std::size_t size() const { return landmarks_.size(); }
  double radius() const { return radius_; }
  /// Landmarks closer than radius() to landmark j (not j itself), nearest first.
  const std::vector<int>& neighbours(int j) const { return neighbours_[j]; }
  /// C_ij: |m_i - m_j| < radius().
  bool local(int i, int j) const;
  /// Appends the landmarks within `r` of `center` (grid query: O(cells + landmarks in them)).
  void query(const Eigen::Vector2d& center, double r, std::vector<int>* out) const;
  /// Largest landmark position variance (trace), to widen a query by the map's uncertainty.
  double maxVariance() const { return max_variance_; }

 private:
  using CellKey = std::int64_t;
  CellKey keyOf(const Eigen::Vector2d& p) const;

  std::vector<MapLandmark> landmarks_;
  std::vector<std::vector<int>> neighbours_;
  std::unordered_map<CellKey, std::vector<int>> cells_;
  double radius_ = 0.0;
  double max_variance_ = 0.0;
};

/// `cov` with its eigenvalues capped at sigma^2 (sigma <= 0: unchanged).
Eigen::Matrix2d capCovariance(const Eigen::Matrix2d& cov, double sigma);

/// A pairing of an observed point with a map landmark.
struct PointPairing {
  const ObservedPoint* obs;
  const MapLandmark* landmark;
};

/// The vehicle pose from pairings (at least 2).
struct PoseFit {
  bool ok = false;
  Eigen::Vector3d pose = Eigen::Vector3d::Zero();  ///< base_link in the map frame
  /// (J^T W J)^-1 with W_i = (C_j + R(phi) cov_i R(phi)^T)^-1, landmarks taken as independent.
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
  /// sum of r_i^T W_i r_i at the pose, r_i = m_j - (R(phi) p_i + t): chi2 with 2k - 3 dof.
  double d2 = 0.0;
};

/// Closed-form least-squares 2D alignment of the observed points onto the landmarks (centroids
/// and one atan2), then `iterations` weighted Gauss-Newton steps with the full covariances.
PoseFit fitPose(const std::vector<PointPairing>& pairings, int iterations = 3);

}  // namespace ekf_slam
