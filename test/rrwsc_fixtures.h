// Scenes for the RRW&SC matcher and relocaliser tests: a random map of landmarks at least
// `spacing` apart and one noisy range-bearing scan of it from a true sensor pose.
#pragma once

#include <cmath>
#include <random>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "ekf_slam/core/association/data_association.h"
#include "ekf_slam/core/common/angles.h"

namespace rrwsc_test {

inline std::vector<Eigen::Vector2d> randomMap(int n, double half_size, double spacing,
                                              unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-half_size, half_size);
  std::vector<Eigen::Vector2d> map;
  while (static_cast<int>(map.size()) < n) {
    const Eigen::Vector2d q(u(rng), u(rng));
    bool far = true;
    for (const auto& o : map) far = far && (o - q).norm() >= spacing;
    if (far) map.push_back(q);
  }
  return map;
}

struct Scan {
  std::vector<ekf_slam::Observation> observations;
  std::vector<int> truth;  ///< landmark index per observation, -1 for clutter
};

/// Every landmark not in `hidden` seen from `sensor` (x, y, yaw) with noise sigma (range,
/// bearing), plus `clutter` random points.
inline Scan scanOf(const std::vector<Eigen::Vector2d>& map, const Eigen::Vector3d& sensor,
                   const Eigen::Vector2d& sigma, unsigned seed, const std::vector<int>& hidden = {},
                   int clutter = 0) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> n01(0.0, 1.0);
  Scan s;
  auto add = [&](const Eigen::Vector2d& p, int truth) {
    const Eigen::Vector2d d = p - sensor.head<2>();
    ekf_slam::Observation o;
    o.z = {d.norm() + sigma.x() * n01(rng),
           ekf_slam::wrapAngle(std::atan2(d.y(), d.x()) - sensor.z() + sigma.y() * n01(rng))};
    o.R = Eigen::Vector2d(sigma.x() * sigma.x(), sigma.y() * sigma.y()).asDiagonal();
    s.observations.push_back(o);
    s.truth.push_back(truth);
  };
  for (int j = 0; j < static_cast<int>(map.size()); ++j) {
    bool is_hidden = false;
    for (int h : hidden) is_hidden = is_hidden || h == j;
    if (!is_hidden) add(map[j], j);
  }
  std::uniform_real_distribution<double> u(-80.0, 80.0);
  for (int k = 0; k < clutter; ++k) add(sensor.head<2>() + Eigen::Vector2d(u(rng), u(rng)), -1);
  return s;
}

}  // namespace rrwsc_test
