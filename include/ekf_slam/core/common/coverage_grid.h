// Where a sensor has looked: a coarse grid in the map frame counting, per cell, the scans whose
// sensing region (SensorModel) contained the cell's centre. DJNN uses it for the density of
// landmarks not in the map (docs/djnn.md, "Where the sensor has looked"). ROS-free.
#pragma once

#include <cstdint>
#include <unordered_map>
#include <vector>

#include <Eigen/Core>

#include "ekf_slam/core/common/sensor_model.h"

namespace ekf_slam {

class CoverageGrid {
 public:
  /// cell: side of a square cell [m] (> 0).
  explicit CoverageGrid(double cell = 0.2);

  double cell() const { return cell_; }
  void clear() { counts_.clear(); }
  /// Cells with a count.
  std::size_t size() const { return counts_.size(); }

  /// Counts one look of the sensor at `sensor_pose` (x, y, heading; map frame): every cell whose
  /// centre lies in the sensor's region (SensorModel::contains, no margin) gains 1 (saturating).
  /// Visits only the cells of the region's bounding box: O(cells of the view).
  void addView(const SensorModel& sensor, const Eigen::Vector3d& sensor_pose);

  /// Looks counted at the cell containing p.
  int count(const Eigen::Vector2d& p) const;

  /// The mean of table[min(count, table.size() - 1)] over a Gaussian N(mean, C) of a point:
  /// cells whose centre lies within `k` standard deviations (e^T C^-1 e <= k^2), weighted by the
  /// density there; the cell containing the mean alone when none does. Returns `fallback` when
  /// the ellipse's bounding box spans more than `max_cells` cells (too uncertain to tell).
  double expectation(const Eigen::Vector2d& mean, const Eigen::Matrix2d& C,
                     const std::vector<double>& table, double k, int max_cells,
                     double fallback) const;

 private:
  using Key = std::int64_t;
  static Key key(std::int64_t ix, std::int64_t iy);
  std::int64_t index(double v) const;

  double cell_;
  std::unordered_map<Key, std::uint16_t> counts_;
};

}  // namespace ekf_slam
