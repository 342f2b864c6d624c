// Crafted maps and scans for the relocaliser tests:
//
//   reloc_test::World w = reloc_test::randomMap(60, 100.0, 4.0, /*seed=*/1);  // irregular
//   auto obs = w.observe(pose, 14.0, &truth, /*noise=*/true);   // what a laser would see
//   FGCBB f;  f.setMap(w.map);  auto r = f.relocalise(obs, w.sensor_offset, nullptr);
//
// Landmark ids are 100 + index so tests cannot confuse ids with indices.
#pragma once

#include <cmath>
#include <random>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Eigenvalues>

#include "ekf_slam/core/common/angles.h"
#include "ekf_slam/core/filter/observation_model.h"
#include "ekf_slam/core/relocalisation/relocaliser.h"

namespace ekf_slam {
namespace reloc_test {

constexpr double kSigmaRange = 0.1;
constexpr double kSigmaBearing = 0.5 * M_PI / 180.0;
constexpr double kMapSigma = 0.1;

struct World {
  std::vector<MapLandmark> map;
  Eigen::Vector3d sensor_offset{0.5, 0.2, 0.0};

  void add(double x, double y, double descriptor = std::numeric_limits<double>::quiet_NaN()) {
    MapLandmark l;
    l.id = 100 + static_cast<LandmarkId>(map.size());
    l.position = Eigen::Vector2d(x, y);
    l.covariance = Eigen::Vector2d(kMapSigma * kMapSigma, kMapSigma * kMapSigma).asDiagonal();
    l.descriptor = descriptor;
    map.push_back(l);
  }

  /// Every landmark within `range` of the sensor at vehicle pose `pose`, in map order, with
  /// optional noise; `truth` gets the id of each observation's landmark.
  std::vector<Observation> observe(const Eigen::Vector3d& pose, double range,
                                   std::vector<LandmarkId>* truth, bool noise = true,
                                   unsigned seed = 7) const {
    std::mt19937 rng(seed);
    std::normal_distribution<double> n(0.0, 1.0);
    const RangeBearingModel model(sensor_offset);
    std::vector<Observation> out;
    if (truth) truth->clear();
    for (const MapLandmark& l : map) {
      Eigen::Vector2d z = model.predict(pose, l.position);
      if (z.x() > range) continue;
      if (noise) z += Eigen::Vector2d(kSigmaRange * n(rng), kSigmaBearing * n(rng));
      Observation o;
      o.z = z;
      o.R = Eigen::Vector2d(kSigmaRange * kSigmaRange, kSigmaBearing * kSigmaBearing).asDiagonal();
      o.descriptor = l.descriptor;
      out.push_back(o);
      if (truth) truth->push_back(l.id);
    }
    return out;
  }
};

/// `n` landmarks uniformly in a `size` x `size` square, no two closer than `min_spacing`.
inline World randomMap(int n, double size, double min_spacing, unsigned seed) {
  World w;
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0.0, size);
  int tries = 0;
  while (static_cast<int>(w.map.size()) < n && ++tries < 100000) {
    const Eigen::Vector2d p(u(rng), u(rng));
    bool ok = true;
    for (const MapLandmark& l : w.map) ok = ok && (l.position - p).norm() >= min_spacing;
    if (ok) w.add(p.x(), p.y());
  }
  return w;
}

/// A regular grid of `nx` x `ny` landmarks `spacing` apart, from the origin.
inline World gridMap(int nx, int ny, double spacing) {
  World w;
  for (int i = 0; i < nx; ++i) {
    for (int j = 0; j < ny; ++j) w.add(i * spacing, j * spacing);
  }
  return w;
}

inline double positionError(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return (a.head<2>() - b.head<2>()).norm();
}
inline double headingError(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::abs(wrapAngle(a.z() - b.z()));
}

}  // namespace reloc_test
}  // namespace ekf_slam
