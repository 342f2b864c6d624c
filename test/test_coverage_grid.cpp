// CoverageGrid (core/coverage_grid.h): looks counted per cell along a crafted trajectory, and the
// mean of a per-count table over a Gaussian.
#include <cmath>
#include <vector>

#include <gtest/gtest.h>

#include "ekf_slam/core/common/coverage_grid.h"

namespace ekf_slam {
namespace test_coverage_grid {

// A downward camera's trapezoid 0.8..4.5 m ahead (the fiducials world's).
SensorModel trapezoid() {
  SensorModel s;
  s.min_range = 0.8;
  s.max_range = 4.75;
  s.field_of_view = 2.0 * M_PI;
  s.polygon = {{0.8, -0.5}, {4.5, -1.5}, {4.5, 1.5}, {0.8, 0.5}};
  return s;
}

// Driving along x in 0.2 m steps from x = 0 to 10: a cell on the centre line is counted once per
// pose whose trapezoid holds its centre (3.7 m deep: 18-19 poses); behind the start's near edge
// and beyond the last far edge, never; beside the path, only by the wide far part.
TEST(CoverageGrid, CountsTheScansOfACraftedTrajectory) {
  const SensorModel s = trapezoid();
  CoverageGrid g(0.2);
  for (int k = 0; k <= 50; ++k) g.addView(s, Eigen::Vector3d(0.2 * k, 0.0, 0.0));
  auto expected = [&](const Eigen::Vector2d& p) {  // brute force over the poses, at cell centres
    const Eigen::Vector2d c((std::floor(p.x() / 0.2) + 0.5) * 0.2,
                            (std::floor(p.y() / 0.2) + 0.5) * 0.2);
    int n = 0;
    for (int k = 0; k <= 50; ++k) n += s.contains(c - Eigen::Vector2d(0.2 * k, 0.0), 0.0, 0.0);
    return n;
  };
  for (double x = -1.0; x < 16.0; x += 0.37) {
    for (double y = -2.0; y < 2.0; y += 0.23) {
      EXPECT_EQ(g.count({x, y}), expected({x, y})) << x << " " << y;
    }
  }
  EXPECT_EQ(g.count({0.3, 0.1}), 0);            // behind the first pose's near edge
  EXPECT_NEAR(g.count({5.1, 0.1}), 18.5, 0.5);  // mid-path: 3.7 m deep at 0.2 m steps
  EXPECT_EQ(g.count({16.0, 0.1}), 0);           // beyond the last far edge
  EXPECT_GT(g.count({5.1, 1.1}), 0);            // beside the path: the far part only
  EXPECT_LT(g.count({5.1, 1.1}), 18);
  // Heading pi/2: the same counts turned.
  CoverageGrid t(0.2);
  for (int k = 0; k <= 50; ++k) t.addView(s, Eigen::Vector3d(0.0, 0.2 * k, M_PI / 2));
  EXPECT_NEAR(t.count({-0.1, 5.1}), 18.5, 1.5);  // cos(pi / 2) is not 0: a border cell may go
  EXPECT_EQ(t.count({0.1, 0.3}), 0);
  g.clear();
  EXPECT_EQ(g.size(), 0u);
  EXPECT_EQ(g.count({5.1, 0.1}), 0);
}

// The mean over a Gaussian: a point well inside a covered area takes the covered cells' value; a
// point whose uncertainty reaches never-looked cells is pulled towards their value; too wide an
// ellipse returns the fallback.
TEST(CoverageGrid, ExpectationOverAGaussian) {
  const SensorModel s = trapezoid();
  CoverageGrid g(0.2);
  for (int k = 0; k <= 50; ++k) g.addView(s, Eigen::Vector3d(0.2 * k, 0.0, 0.0));
  std::vector<double> table = {1.0};
  for (int n = 1; n <= 10; ++n) table.push_back(table.back() * 0.3);
  const double k = 3.0;
  // 5 cm: one cell, looked at 19 times (capped at 10).
  const Eigen::Matrix2d small = Eigen::Matrix2d::Identity() * 0.05 * 0.05;
  EXPECT_NEAR(g.expectation({5.1, 0.1}, small, table, k, 4096, -1.0), table[10], 1e-12);
  EXPECT_NEAR(g.expectation({0.3, 0.1}, small, table, k, 4096, -1.0), 1.0, 1e-12);
  // 1 m across the path: part of the mass lies beside the swath, never looked at.
  Eigen::Matrix2d across = Eigen::Matrix2d::Identity() * 0.05 * 0.05;
  across(1, 1) = 1.0;
  const double wide = g.expectation({5.1, 0.1}, across, table, k, 4096, -1.0);
  EXPECT_GT(wide, 0.1);
  EXPECT_LT(wide, 1.0);
  // 1 m along the path, in its middle: still well covered.
  Eigen::Matrix2d along = across;
  std::swap(along(0, 0), along(1, 1));
  EXPECT_LT(g.expectation({5.1, 0.1}, along, table, k, 4096, -1.0), 0.01);
  // Too many cells: the fallback.
  EXPECT_EQ(g.expectation({5.1, 0.1}, Eigen::Matrix2d::Identity() * 100.0, table, k, 4096, -1.0),
            -1.0);
  EXPECT_THROW(CoverageGrid(0.0), std::invalid_argument);
}

}  // namespace test_coverage_grid
}  // namespace ekf_slam
