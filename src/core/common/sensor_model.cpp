// Sensor region and detection model. See sensor_model.h and docs/djnn.md.
#include "ekf_slam/core/common/sensor_model.h"

#include <algorithm>
#include <sstream>
#include <stdexcept>

namespace ekf_slam {

namespace {

// Twice the signed area: > 0 for a counter-clockwise polygon.
double signedArea2(const std::vector<Eigen::Vector2d>& poly) {
  double a = 0.0;
  for (std::size_t i = 0; i < poly.size(); ++i) {
    const Eigen::Vector2d& p = poly[i];
    const Eigen::Vector2d& q = poly[(i + 1) % poly.size()];
    a += p.x() * q.y() - q.x() * p.y();
  }
  return a;
}

}  // namespace

bool SensorModel::contains(const Eigen::Vector2d& p, double radial, double lateral) const {
  const double r_max = max_range + radial;
  if (!(p.squaredNorm() < r_max * r_max)) return false;
  const double r_min = min_range - radial;
  if (min_range > 0.0 && r_min > 0.0 && !(p.squaredNorm() > r_min * r_min)) return false;
  if (field_of_view < 2.0 * M_PI) {
    // Signed distance to the nearer edge ray of the wedge (exactly x at 180 deg).
    const double a = 0.5 * field_of_view;
    if (!(std::sin(a) * p.x() - std::cos(a) * std::abs(p.y()) > -lateral)) return false;
  }
  if (polygon.size() >= 3) {
    // Convex polygon: the inward distance to every edge line must exceed -lateral (the polygon
    // with its edges pushed out by `lateral`, a mitred superset of the rounded dilation).
    const double orient = signedArea2(polygon) > 0.0 ? 1.0 : -1.0;
    for (std::size_t i = 0; i < polygon.size(); ++i) {
      const Eigen::Vector2d& a = polygon[i];
      const Eigen::Vector2d e = polygon[(i + 1) % polygon.size()] - a;
      const double inward = orient * (e.x() * (p.y() - a.y()) - e.y() * (p.x() - a.x())) / e.norm();
      if (!(inward > -lateral)) return false;
    }
  }
  return true;
}

double SensorModel::falseDetectionProbability(double area) const {
  if (!(clutter_density > 0.0) || !(area > 0.0)) return 0.0;
  return -std::expm1(-clutter_density * area);
}

void SensorModel::validate(const ParameterReader& r) const {
  if (!(max_range > 0.0)) r.fail("sensor_range", "must be > 0");
  if (!(min_range >= 0.0 && min_range < max_range)) {
    r.fail("min_range", "must lie in [0, sensor_range)");
  }
  if (!(field_of_view > 0.0 && field_of_view <= 2.0 * M_PI)) {
    r.fail("field_of_view", "must lie in (0, 2 pi]");
  }
  if (!(detection_probability > 0.0 && detection_probability <= 1.0)) {
    r.fail("detection_probability", "must lie in (0, 1]");
  }
  if (!(clutter_density >= 0.0) || !std::isfinite(clutter_density)) {
    r.fail("clutter_density", "must be finite and >= 0");
  }
  if (polygon.empty()) return;
  if (const std::string problem = polygonProblem(polygon); !problem.empty())
    r.fail("fov_polygon", problem);
  for (const Eigen::Vector2d& v : polygon) {
    // The region is searched within sensor_range of the sensor (spatial index).
    if (!(v.norm() <= max_range)) r.fail("fov_polygon", "has a vertex beyond sensor_range");
  }
}

std::string polygonProblem(const std::vector<Eigen::Vector2d>& polygon) {
  if (polygon.size() < 3) return "needs at least 3 vertices";
  if (!(std::abs(signedArea2(polygon)) > 0.0)) return "has no area";
  // Convex: every turn has the same sign.
  double sign = 0.0;
  for (std::size_t i = 0; i < polygon.size(); ++i) {
    const Eigen::Vector2d e1 = polygon[(i + 1) % polygon.size()] - polygon[i];
    const Eigen::Vector2d e2 =
        polygon[(i + 2) % polygon.size()] - polygon[(i + 1) % polygon.size()];
    const double turn = e1.x() * e2.y() - e1.y() * e2.x();
    if (turn == 0.0) continue;
    if (sign == 0.0) sign = turn;
    if (turn * sign < 0.0) return "must be convex";
  }
  return "";
}

std::vector<Eigen::Vector2d> parsePolygon(const std::string& text) {
  std::vector<Eigen::Vector2d> out;
  std::stringstream all(text);
  std::string vertex;
  while (std::getline(all, vertex, ';')) {
    if (vertex.find_first_not_of(" \t") == std::string::npos) continue;
    std::stringstream v(vertex);
    double x, y;
    char comma = 0;
    std::string rest;
    if (!(v >> x >> comma >> y) || comma != ',' || (v >> rest) || !std::isfinite(x) ||
        !std::isfinite(y)) {
      throw std::invalid_argument("bad vertex \"" + vertex + "\" (want \"x,y; x,y; ...\")");
    }
    out.emplace_back(x, y);
  }
  if (!out.empty() && out.size() < 3) throw std::invalid_argument("needs at least 3 vertices");
  return out;
}

SensorModel readSensorModel(const ParameterReader& r, const SensorModel& defaults) {
  SensorModel s = defaults;
  s.max_range = r.positive("sensor_range", defaults.max_range);
  s.min_range = r.nonNegative("min_range", defaults.min_range);
  s.field_of_view = r.inRange("field_of_view", defaults.field_of_view, 0.0, 2.0 * M_PI);
  const std::string poly = r.text("fov_polygon", "");
  if (!poly.empty()) {
    try {
      s.polygon = parsePolygon(poly);
    } catch (const std::invalid_argument& e) {
      r.fail("fov_polygon", e.what());
    }
  }
  s.detection_probability =
      r.inRange("detection_probability", defaults.detection_probability, 0.0, 1.0);
  s.clutter_density = r.nonNegative("clutter_density", defaults.clutter_density);
  s.validate(r);
  return s;
}

}  // namespace ekf_slam
