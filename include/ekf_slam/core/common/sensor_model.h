// What a landmark sensor can see and how reliably: minimum and maximum range, a field of view
// (a wedge about the sensor x axis, optionally cut by a convex polygon in the sensor frame, e.g.
// the trapezoid a downward-looking camera sees on the floor), the detection probability P_D of a
// landmark inside that region and the density of false detections (clutter). ROS-free.
// DJNN's local / valid / sensor regions and its evidence score use it (docs/djnn.md).
#pragma once

#include <cmath>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "ekf_slam/core/common/parameters.h"

namespace ekf_slam {

struct SensorModel {
  double min_range = 0.0;       ///< [m]
  double max_range = 30.0;      ///< R [m]
  double field_of_view = M_PI;  ///< full wedge angle about the sensor x axis [rad]
  /// Convex polygon (sensor frame, either winding); empty = no polygon. A point must lie inside
  /// it as well as inside the range annulus and the wedge.
  std::vector<Eigen::Vector2d> polygon;
  double detection_probability = 1.0;  ///< P_D of a landmark inside the region, per scan
  double clutter_density = 0.0;        ///< false detections per m^2 per scan

  /// Whether p (sensor frame) lies in the region grown by `radial` metres in range (outwards at
  /// max_range, inwards at min_range; negative shrinks) and by `lateral` metres across the edges
  /// of the wedge and the polygon (negative shrinks). With both 0: the region itself.
  bool contains(const Eigen::Vector2d& p, double radial, double lateral) const;

  /// Probability that clutter puts at least one false detection into an area [m^2] in one scan
  /// (Poisson clutter): 1 - exp(-clutter_density * area).
  double falseDetectionProbability(double area) const;

  /// Checks the invariants; throws ParameterError naming the parameter (ParameterReader names).
  void validate(const ParameterReader& r) const;
};

/// Reads a sensor model with the parameter names `sensor_range`, `min_range`, `field_of_view`,
/// `fov_polygon` ("x1,y1; x2,y2; ..." in the sensor frame), `detection_probability` and
/// `clutter_density`, defaulting to `defaults`; validates it.
SensorModel readSensorModel(const ParameterReader& r, const SensorModel& defaults = SensorModel());

/// What is wrong with a region's polygon: "needs at least 3 vertices", "has no area", "must be
/// convex"; "" when it is a convex polygon.
std::string polygonProblem(const std::vector<Eigen::Vector2d>& polygon);

/// Parses "x1,y1; x2,y2; ..." (at least 3 vertices; empty text = no polygon). Throws
/// std::invalid_argument on bad syntax.
std::vector<Eigen::Vector2d> parsePolygon(const std::string& text);

}  // namespace ekf_slam
