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
  /// R is the pipeline's default (sigma_range, sigma_bearing), not the sensor's or extractor's
  /// own: noise calibration knows which parameters it would scale.
  bool default_covariance = false;
};

}  // namespace ekf_slam
