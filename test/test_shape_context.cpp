// Shape context descriptors: invariant under rotation and translation of the whole set,
// distinctive between points, chi-square distance bounds.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include <Eigen/Geometry>

#include "ekf_slam/core/graph_matching/shape_context.h"
#include "rrwsc_fixtures.h"

namespace ekf_slam {
namespace test_shape_context {

std::vector<Eigen::Vector2d> transformed(const std::vector<Eigen::Vector2d>& p, double angle,
                                         const Eigen::Vector2d& t) {
  const Eigen::Matrix2d rot = Eigen::Rotation2Dd(angle).toRotationMatrix();
  std::vector<Eigen::Vector2d> out;
  for (const auto& q : p) out.push_back(rot * q + t);
  return out;
}

TEST(ShapeContext, InvariantUnderRotationAndTranslation) {
  const auto points = rrwsc_test::randomMap(30, 60.0, 5.0, 1);
  const ShapeContextParams params;
  std::vector<ShapeContext> a, b;
  shapeContexts(points, params, &a);
  // Angles off the 30 deg bin grid too: the reference direction turns with the set.
  for (double angle : {0.3, 1.0, 2.0, -2.9, M_PI}) {
    shapeContexts(transformed(points, angle, {123.0, -45.0}), params, &b);
    for (std::size_t i = 0; i < points.size(); ++i) {
      EXPECT_NEAR(chiSquareDistance(a[i], b[i]), 0.0, 1e-9) << "angle " << angle << " point " << i;
    }
  }
}

TEST(ShapeContext, DistinguishesThePointsOfARandomSet) {
  const auto points = rrwsc_test::randomMap(30, 60.0, 5.0, 2);
  std::vector<ShapeContext> a, b;
  shapeContexts(points, {}, &a);
  shapeContexts(transformed(points, 1.234, {-7.0, 9.0}), {}, &b);
  int own_best = 0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    std::size_t best = 0;
    for (std::size_t j = 1; j < b.size(); ++j) {
      if (shapeContextDistance(a[i], b[j]) < shapeContextDistance(a[i], b[best])) best = j;
    }
    own_best += best == i;
    // Another point's descriptor is never as close as the point's own.
    for (std::size_t j = 0; j < b.size(); ++j) {
      if (j != i) {
        EXPECT_GT(shapeContextDistance(a[i], b[j]), 0.01);
      }
    }
  }
  EXPECT_EQ(own_best, 30);
}

TEST(ShapeContext, HistogramsAreNormalisedAndFarPointsLeftOut) {
  const std::vector<Eigen::Vector2d> points = {{0, 0}, {10, 0}, {0, 20}, {500, 500}};
  std::vector<ShapeContext> h;
  shapeContexts(points, {2.0, 100.0}, &h);
  EXPECT_NEAR(h[0].sum(), 1.0, 1e-12);
  EXPECT_TRUE(h[3].isZero());  // nothing within 100 m
  EXPECT_NEAR(chiSquareDistance(h[0], h[0]), 0.0, 1e-15);
  ShapeContext x = ShapeContext::Zero(), y = ShapeContext::Zero();
  x[0] = 1.0;
  y[30] = 1.0;
  EXPECT_NEAR(chiSquareDistance(x, y), 1.0, 1e-15);  // disjoint: the maximum
}

TEST(ShapeContext, ShiftToleratesAReferenceTiltedByOneBin) {
  ShapeContext x = ShapeContext::Zero(), y = ShapeContext::Zero();
  x[3] = 0.5;
  x[12 + 7] = 0.5;
  y[4] = 0.5;
  y[12 + 8] = 0.5;  // every angle one bin further
  EXPECT_NEAR(chiSquareDistance(x, y), 1.0, 1e-15);
  EXPECT_NEAR(shapeContextDistance(x, y), 0.0, 1e-15);
}

// The distance visits only the bins non-zero in both histograms (bit masks rotated per ring):
// it must equal the least dense chi-square over the three angle shifts, including the bins that
// wrap around a ring.
TEST(ShapeContext, SparseDistanceEqualsTheDenseOneOverTheShifts) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const auto sparse = [&](double density) {
    ShapeContext h = ShapeContext::Zero();
    for (int k = 0; k < kShapeContextBins; ++k) h[k] = u(rng) < density ? u(rng) : 0.0;
    if (h.sum() > 0.0) h /= h.sum();
    return h;
  };
  // Angle bin k of `a` meets bin k + shift of `b` in the same ring.
  const auto rotated = [](const ShapeContext& b, int shift) {
    ShapeContext r;
    for (int ring = 0; ring < kShapeContextDistanceBins; ++ring) {
      for (int k = 0; k < kShapeContextAngleBins; ++k) {
        const int from = (k + shift + kShapeContextAngleBins) % kShapeContextAngleBins;
        r[ring * kShapeContextAngleBins + k] = b[ring * kShapeContextAngleBins + from];
      }
    }
    return r;
  };
  for (int trial = 0; trial < 200; ++trial) {
    const ShapeContext a = sparse(trial % 2 ? 0.3 : 0.8), b = sparse(trial % 3 ? 0.3 : 0.0);
    double dense = 1.0;
    for (int shift = -1; shift <= 1; ++shift) {
      dense = std::min(dense, chiSquareDistance(a, rotated(b, shift)));
    }
    EXPECT_NEAR(shapeContextDistance(a, b), dense, 1e-12) << "trial " << trial;
  }
}

}  // namespace test_shape_context
}  // namespace ekf_slam
