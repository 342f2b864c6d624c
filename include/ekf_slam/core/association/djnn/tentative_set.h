// DJNN's tentative features (eq. 9): observations not yet in the map, each with its fused
// position, evidence counter and sightings, kept in slots with a grid index so that a scan
// visits only the features near the sensor.
#pragma once

#include <cstddef>
#include <cstdint>
#include <unordered_map>
#include <vector>

#include <Eigen/Core>

#include "ekf_slam/core/association/data_association.h"  // FeatureKey
#include "ekf_slam/core/filter/ekf_slam.h"               // LandmarkId

namespace ekf_slam {

/// One sighting of a tentative feature as measured, for the static test against the poses it was
/// taken from (StaticTest, pose clones).
struct FeatureSighting {
  double stamp = 0.0;
  Eigen::Vector2d z = Eigen::Vector2d::Zero();
  Eigen::Matrix2d R = Eigen::Matrix2d::Zero();
  MeasurementKind kind = MeasurementKind::kRangeBearing;
};

/// One tentative feature. The fields past `evidence` serve the extensions (static test, velocity
/// track, remembered features); the paper's algorithm reads position, cov, evidence, last_seen.
struct Tentative {
  Eigen::Vector2d position = Eigen::Vector2d::Zero();
  Eigen::Matrix2d cov = Eigen::Matrix2d::Zero();  ///< observation-noise part only
  /// d(position) / d(heading) of the fused sightings: the lever of the fused position, fused
  /// like it (the static test's heading term, the pose-following gate).
  Eigen::Vector2d heading_lever = Eigen::Vector2d::Zero();
  double evidence = 0.0;
  double last_seen = 0.0;
  bool alive = false;
  /// The run of sightings since the last (re)start: AssociationResult::feature.
  FeatureKey key = kNoFeature;
  int sightings = 0;      ///< fused since the last (re)start and counted by the static test
  double residual = 0.0;  ///< sum of normalised residuals of the sightings (static test)
  /// Constant-velocity fit of the sightings since the last (re)start (static_min_speed):
  /// information matrix and vector of (position at first_seen, velocity).
  double first_seen = 0.0;
  Eigen::Matrix4d track_info = Eigen::Matrix4d::Zero();
  Eigen::Vector4d track_vec = Eigen::Vector4d::Zero();
  /// Nearest recently paired map landmark at the last sighting and the offset to it
  /// (remembered features).
  LandmarkId anchor = kNoLandmark;
  Eigen::Vector2d anchor_offset = Eigen::Vector2d::Zero();
  Eigen::Matrix2d anchor_cov = Eigen::Matrix2d::Zero();
  /// The pose's uncertainty at the feature's place at its last sighting (position, and heading
  /// times the lever): a feature seen with no anchor is anchored at its timeout with it.
  Eigen::Matrix2d pose_cov = Eigen::Matrix2d::Zero();
  bool held_birth = false;  ///< started by an observation the joint decision held
  /// The latest sighting failed the static test by chance (chance_failures_without_movers): it is
  /// left out of the history.
  bool chance_failure = false;
  /// Anchored polar form (second-order observations: far returns, coarse bearings): range and
  /// world bearing of the feature from the sensor position of the run's first sighting, and
  /// their covariance. position and cov are then its mean and covariance in the map frame.
  bool polar = false;
  Eigen::Vector2d polar_origin = Eigen::Vector2d::Zero();
  Eigen::Vector2d polar_y = Eigen::Vector2d::Zero();
  Eigen::Matrix2d polar_cov = Eigen::Matrix2d::Zero();
  /// The latest sightings since the last (re)start, oldest first (at most
  /// StaticTest::kMaxJointSightings).
  std::vector<FeatureSighting> history;
};

class TentativeSet {
 public:
  /// Side of the index's cells [m].
  void setCell(double cell) { cell_ = cell; }
  void clear();
  bool empty() const { return cells_.empty(); }
  std::size_t slots() const { return features_.size(); }
  Tentative& operator[](int slot) { return features_[slot]; }
  const Tentative& operator[](int slot) const { return features_[slot]; }

  /// A new live feature at `position` (its other fields are the caller's to start).
  int add(const Eigen::Vector2d& position);
  /// Frees the slot of a live feature.
  void remove(int slot);
  void move(int slot, const Eigen::Vector2d& position);
  /// Live features within `radius` of `center`, in slot order.
  void query(const Eigen::Vector2d& center, double radius, std::vector<int>* out) const;
  /// The next slot of a round-robin over all slots (the amortised timeout sweep).
  int nextSweepSlot();

 private:
  using CellKey = std::int64_t;
  CellKey keyOf(const Eigen::Vector2d& p) const;
  void unindex(int slot, CellKey key);

  double cell_ = 10.0;
  std::vector<Tentative> features_;
  std::vector<int> free_slots_;
  std::unordered_map<CellKey, std::vector<int>> cells_;
  std::size_t sweep_ = 0;
};

}  // namespace ekf_slam
