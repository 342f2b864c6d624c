// Where a sensor has looked (coverage_grid.h; docs/djnn.md, "Where the sensor has looked").
#include "ekf_slam/core/common/coverage_grid.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include <Eigen/LU>

namespace ekf_slam {

namespace {
constexpr std::uint16_t kMaxCount = std::numeric_limits<std::uint16_t>::max();
}

CoverageGrid::CoverageGrid(double cell) : cell_(cell) {
  if (!(cell > 0.0)) throw std::invalid_argument("CoverageGrid: cell must be > 0");
}

CoverageGrid::Key CoverageGrid::key(std::int64_t ix, std::int64_t iy) {
  return static_cast<Key>((static_cast<std::uint64_t>(ix) << 32) ^
                          (static_cast<std::uint64_t>(iy) & 0xffffffffULL));
}

std::int64_t CoverageGrid::index(double v) const {
  const double c = std::floor(v / cell_);
  return static_cast<std::int64_t>(std::max(-1.0e9, std::min(1.0e9, c)));
}

void CoverageGrid::addView(const SensorModel& sensor, const Eigen::Vector3d& sensor_pose) {
  // The region's bounding box in the sensor frame: the polygon's, within the range disc.
  const double R = sensor.max_range;
  Eigen::Vector2d lo(-R, -R), hi(R, R);
  if (!sensor.polygon.empty()) {
    Eigen::Vector2d plo = sensor.polygon.front(), phi = plo;
    for (const Eigen::Vector2d& v : sensor.polygon) {
      plo = plo.cwiseMin(v);
      phi = phi.cwiseMax(v);
    }
    lo = lo.cwiseMax(plo);
    hi = hi.cwiseMin(phi);
  }
  const double c = std::cos(sensor_pose(2)), s = std::sin(sensor_pose(2));
  Eigen::Matrix2d rot;
  rot << c, -s, s, c;
  const Eigen::Vector2d t = sensor_pose.head<2>();
  Eigen::Vector2d wlo = Eigen::Vector2d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Vector2d whi = -wlo;
  for (int corner = 0; corner < 4; ++corner) {
    const Eigen::Vector2d p(corner & 1 ? hi.x() : lo.x(), corner & 2 ? hi.y() : lo.y());
    const Eigen::Vector2d w = t + rot * p;
    wlo = wlo.cwiseMin(w);
    whi = whi.cwiseMax(w);
  }
  for (std::int64_t ix = index(wlo.x()); ix <= index(whi.x()); ++ix) {
    for (std::int64_t iy = index(wlo.y()); iy <= index(whi.y()); ++iy) {
      const Eigen::Vector2d centre((ix + 0.5) * cell_, (iy + 0.5) * cell_);
      if (!sensor.contains(rot.transpose() * (centre - t), 0.0, 0.0)) continue;
      std::uint16_t& n = counts_[key(ix, iy)];
      if (n < kMaxCount) ++n;
    }
  }
}

int CoverageGrid::count(const Eigen::Vector2d& p) const {
  const auto it = counts_.find(key(index(p.x()), index(p.y())));
  return it == counts_.end() ? 0 : it->second;
}

double CoverageGrid::expectation(const Eigen::Vector2d& mean, const Eigen::Matrix2d& C,
                                 const std::vector<double>& table, double k, int max_cells,
                                 double fallback) const {
  if (table.empty()) return fallback;
  const auto value = [&](std::int64_t ix, std::int64_t iy) {
    const auto it = counts_.find(key(ix, iy));
    const std::size_t n = it == counts_.end() ? 0 : it->second;
    return table[std::min(n, table.size() - 1)];
  };
  const double det = C.determinant();
  if (!(det > 0.0)) return value(index(mean.x()), index(mean.y()));
  const Eigen::Matrix2d W = C.inverse();
  // Half-extents of the ellipse e^T C^-1 e <= k^2: k sqrt(C_xx), k sqrt(C_yy).
  const double hx = k * std::sqrt(C(0, 0)), hy = k * std::sqrt(C(1, 1));
  const std::int64_t x0 = index(mean.x() - hx), x1 = index(mean.x() + hx);
  const std::int64_t y0 = index(mean.y() - hy), y1 = index(mean.y() + hy);
  if (static_cast<double>(x1 - x0 + 1) * static_cast<double>(y1 - y0 + 1) > max_cells) {
    return fallback;
  }
  double sum = 0.0, weight = 0.0;
  for (std::int64_t ix = x0; ix <= x1; ++ix) {
    for (std::int64_t iy = y0; iy <= y1; ++iy) {
      const Eigen::Vector2d e = Eigen::Vector2d((ix + 0.5) * cell_, (iy + 0.5) * cell_) - mean;
      const double d2 = e.dot(W * e);
      if (d2 > k * k) continue;
      const double w = std::exp(-0.5 * d2);
      sum += w * value(ix, iy);
      weight += w;
    }
  }
  return weight > 0.0 ? sum / weight : value(index(mean.x()), index(mean.y()));
}

}  // namespace ekf_slam
