#include "ekf_slam/core/feature_extraction/scan_geometry.h"

#include <cmath>

namespace ekf_slam {

const char* scanGeometryError(std::size_t beams, double angle_min, double angle_max,
                              double angle_increment) {
  if (!std::isfinite(angle_min) || !std::isfinite(angle_max) || !std::isfinite(angle_increment))
    return "non-finite angle_min, angle_max or angle_increment";
  if (beams == 0) return nullptr;  // an empty scan: nothing to place (counted as empty)
  const double inc = std::abs(angle_increment);
  const double span = angle_max - angle_min;
  if (angle_increment == 0.0 && beams > 1) return "angle_increment is zero";
  // Slack for float32 angles: a relative 1e-3 of an increment, and 1e-6 rad.
  const double slack = inc * (1.0 + 1e-3) + 1e-6;
  if (span != 0.0 && (span > 0.0) != (angle_increment > 0.0) && std::abs(span) > 1e-6)
    return "the sign of angle_increment contradicts angle_min -> angle_max";
  if (std::abs(span) > 2.0 * M_PI + slack)
    return "angle_min -> angle_max spans more than a full turn";
  // Too many or too few beams for the angles, or an increment that does not fit them.
  const double covered = static_cast<double>(beams - 1) * inc;
  if (std::abs(covered - std::abs(span)) > slack)
    return "the number of ranges does not match angle_min, angle_max and angle_increment";
  return nullptr;
}

}  // namespace ekf_slam
