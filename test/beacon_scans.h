// Synthetic laser scans with intensities for the beacon tests: beams ray-cast against cylinders
// (each with its own intensity) in front of a dull wall.
#pragma once

#include <cmath>
#include <vector>

#include "ekf_slam/core/feature_extraction/feature_extractor.h"

namespace beacon_scans {

struct Cylinder {
  double x, y, radius, intensity;  ///< in the sensor frame [m]
};

/// 361 beams over 180 deg (0.5 deg), wall at `wall` m with intensity 100.
inline ekf_slam::LaserScanData scanOf(const std::vector<Cylinder>& cylinders, double wall = 25.0) {
  ekf_slam::LaserScanData s;
  s.angle_min = -M_PI / 2;
  s.angle_increment = M_PI / 360.0;
  s.range_max = 80.0;
  for (int i = 0; i <= 360; ++i) {
    const double a = s.angle_min + i * s.angle_increment;
    const double dx = std::cos(a), dy = std::sin(a);
    double best = wall, intensity = 100.0;
    for (const Cylinder& c : cylinders) {
      const double along = c.x * dx + c.y * dy;
      const double d2 = c.x * c.x + c.y * c.y - along * along;
      if (d2 > c.radius * c.radius || along <= 0.0) continue;
      const double t = along - std::sqrt(c.radius * c.radius - d2);
      if (t < best) {
        best = t;
        intensity = c.intensity;
      }
    }
    s.ranges.push_back(static_cast<float>(best));
    s.intensities.push_back(static_cast<float>(intensity));
  }
  return s;
}

}  // namespace beacon_scans
