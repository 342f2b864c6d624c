// Angle helpers shared by every model. ROS-free.
#pragma once

#include <cmath>

namespace ekf_slam {

/// Wraps an angle to (-pi, pi].
inline double wrapAngle(double a) {
  a = std::remainder(a, 2.0 * M_PI);  // [-pi, pi]
  return a <= -M_PI ? a + 2.0 * M_PI : a;
}

inline double deg2rad(double d) { return d * M_PI / 180.0; }
inline double rad2deg(double r) { return r * 180.0 / M_PI; }

}  // namespace ekf_slam
