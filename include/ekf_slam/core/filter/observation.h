// One observation of a point landmark, as the extractors produce it and the filter, the
// associators and the relocalisers take it.
#pragma once

#include <limits>

#include <Eigen/Core>

#include "ekf_slam/core/filter/observation_model.h"  // MeasurementKind

namespace ekf_slam {

/// One observation of the current scan.
struct Observation {
  Eigen::Vector2d z = Eigen::Vector2d::Zero();      ///< (range, bearing) or (x, y), sensor frame
  Eigen::Matrix2d R = Eigen::Matrix2d::Identity();  ///< measurement noise covariance, same units
  MeasurementKind kind = MeasurementKind::kRangeBearing;
  /// Optional descriptor, e.g. the trunk diameter [m]; NaN when unknown.
  double descriptor = std::numeric_limits<double>::quiet_NaN();
};

}  // namespace ekf_slam
