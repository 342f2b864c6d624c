// Spatial index over the map's landmark positions: a uniform grid hashed by cell, so that local
// queries cost O(nearby landmarks), not O(map). ROS-free.
#pragma once

#include <cstdint>
#include <unordered_map>
#include <vector>

#include <Eigen/Core>

#include "ekf_slam/core/filter/ekf_slam.h"

namespace ekf_slam {

class LandmarkIndex {
 public:
  explicit LandmarkIndex(double cell_size = 10.0);

  /// Brings the index in step with the EKF: adds new landmarks, drops removed ones, re-bins those
  /// whose estimate left their cell. O(n), called after each EKF change (its cost is dominated
  /// by the O(n^2) update that made it necessary).
  void sync(const EkfSlam& ekf);
  void clear();

  /// Appends the state-order indices (as in EkfSlam::landmark(index)) of every landmark whose
  /// current estimate lies within `radius` of `center`. Exact (checks positions), in O(cells
  /// touched + landmarks in them).
  void query(const EkfSlam& ekf, const Eigen::Vector2d& center, double radius,
             std::vector<int>* indices) const;

  std::size_t size() const { return cell_of_.size(); }
  double cellSize() const { return cell_; }

 private:
  using CellKey = std::int64_t;
  CellKey keyOf(const Eigen::Vector2d& p) const;
  static CellKey key(std::int64_t ix, std::int64_t iy);

  double cell_;
  std::unordered_map<CellKey, std::vector<LandmarkId>> cells_;
  std::unordered_map<LandmarkId, CellKey> cell_of_;
};

}  // namespace ekf_slam
