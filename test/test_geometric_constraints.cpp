// The geometry FGCBB and GCBB share: observations as points, the unary and binary constraints,
// the locality table and the pose from pairings.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "ekf_slam/core/common/angles.h"
#include "ekf_slam/core/relocalisation/geometric_constraints.h"
#include "relocalisation_fixtures.h"

namespace ekf_slam {
namespace test_geometric_constraints {

using reloc_test::World;

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

TEST(ObservedPoints, PlacesObservationsOnBaseLinkThroughTheSensorOffset) {
  std::vector<Observation> obs(1);
  obs[0].z = Eigen::Vector2d(10.0, M_PI / 2);  // 10 m to the sensor's left
  obs[0].R = Eigen::Vector2d(0.01, 0.0001).asDiagonal();
  const auto pts = observedPoints(obs, Eigen::Vector3d(2.0, 1.0, M_PI / 2), 30.0);
  ASSERT_EQ(pts.size(), 1u);
  // Sensor turned 90 deg: its left is base_link's -x.
  EXPECT_NEAR(pts[0].p.x(), 2.0 - 10.0, 1e-9);
  EXPECT_NEAR(pts[0].p.y(), 1.0, 1e-9);
  // Range noise along the ray (base x), bearing noise across it: r^2 * 1e-4 = 0.01.
  EXPECT_NEAR(pts[0].cov(0, 0), 0.01, 1e-12);
  EXPECT_NEAR(pts[0].cov(1, 1), 0.01, 1e-12);
}

TEST(ObservedPoints, DropsInvalidAndFarObservations) {
  std::vector<Observation> obs(5);
  for (auto& o : obs) o.R = Eigen::Matrix2d::Identity() * 0.01;
  obs[0].z = Eigen::Vector2d(5.0, 0.1);   // kept
  obs[1].z = Eigen::Vector2d(kNaN, 0.1);  // not finite
  obs[2].z = Eigen::Vector2d(40.0, 0.1);  // beyond the range
  obs[3].z = Eigen::Vector2d(5.0, 0.2);
  obs[3].R.setZero();                    // R not positive definite
  obs[4].z = Eigen::Vector2d(6.0, 0.3);  // kept, NaN descriptor is fine
  const auto pts = observedPoints(obs, Eigen::Vector3d::Zero(), 16.0);
  ASSERT_EQ(pts.size(), 2u);
  EXPECT_EQ(pts[0].input, 0);
  EXPECT_EQ(pts[1].input, 4);
}

TEST(UnaryConstraint, GatesTheDescriptorDifferenceAndSkipsUnknownOnes) {
  const double var = 2.0 * 0.1 * 0.1, gate = 3.841;
  EXPECT_TRUE(unaryCompatible(0.5, 0.55, var, gate));
  EXPECT_FALSE(unaryCompatible(0.5, 1.0, var, gate));
  EXPECT_TRUE(unaryCompatible(kNaN, 1.0, var, gate));
  EXPECT_TRUE(unaryCompatible(0.5, kNaN, var, gate));
}

TEST(BinaryConstraint, ComparesPairwiseDistancesWithTheirCovariances) {
  const Eigen::Matrix2d C = Eigen::Matrix2d::Identity() * 0.01;
  const Eigen::Vector2d a(0, 0), b(10, 0);
  // The same distance in another place and orientation: statistic 0.
  EXPECT_NEAR(binaryStatistic(a, C, b, C, {50, 50}, C, {50, 60}, C), 0.0, 1e-12);
  // 0.2 m off with variance 4 * 0.01 along the pair: 0.04 / 0.04 = 1.
  EXPECT_NEAR(binaryStatistic(a, C, b, C, {0, 0}, C, {10.2, 0}, C), 1.0, 1e-9);
  // 2 m off: far outside chi2(1, 0.99) = 6.63.
  EXPECT_GT(binaryStatistic(a, C, b, C, {0, 0}, C, {12, 0}, C), 6.63);
  // A larger covariance across the pair does not help, along it does.
  const Eigen::Matrix2d across = Eigen::Vector2d(0.01, 1.0).asDiagonal();
  const Eigen::Matrix2d along = Eigen::Vector2d(1.0, 0.01).asDiagonal();
  EXPECT_GT(binaryStatistic(a, across, b, across, {0, 0}, C, {11, 0}, C), 6.63);
  EXPECT_LT(binaryStatistic(a, along, b, along, {0, 0}, C, {11, 0}, C), 6.63);
}

TEST(CapCovariance, CapsTheEigenvaluesAndKeepsTheAxes) {
  // 3 m along 30 deg, 0.1 m across it.
  const Eigen::Matrix2d Rot = Eigen::Rotation2Dd(deg2rad(30.0)).toRotationMatrix();
  const Eigen::Matrix2d C = Rot * Eigen::Vector2d(9.0, 0.01).asDiagonal() * Rot.transpose();
  const Eigen::Matrix2d c = capCovariance(C, 0.5);
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> es(c);
  EXPECT_NEAR(es.eigenvalues()(0), 0.01, 1e-12);  // the small one is kept
  EXPECT_NEAR(es.eigenvalues()(1), 0.25, 1e-12);  // the large one capped at 0.5^2
  const Eigen::Vector2d axis = es.eigenvectors().col(1);
  EXPECT_NEAR(std::abs(axis.dot(Rot.col(0))), 1.0, 1e-9);  // along the same axis
  EXPECT_TRUE(capCovariance(C, 0.0).isApprox(C));          // 0: unchanged
  EXPECT_TRUE(capCovariance(C, 5.0).isApprox(C));          // below the cap: unchanged
  Eigen::Matrix2d bad = C;
  bad(0, 1) = kNaN;
  EXPECT_FALSE(capCovariance(bad, 0.5).allFinite());  // left for MapPairTable to skip
}

TEST(MapPairTable, NeighboursAreExactlyTheMapPairsCloserThanTheRadius) {
  const World w = reloc_test::randomMap(200, 150.0, 2.0, 3);
  MapPairTable t;
  t.build(w.map, 16.0);
  ASSERT_EQ(t.size(), w.map.size());
  for (std::size_t j = 0; j < t.size(); ++j) {
    std::vector<int> expected;
    for (std::size_t l = 0; l < t.size(); ++l) {
      if (l != j && (w.map[l].position - w.map[j].position).norm() < 16.0)
        expected.push_back(static_cast<int>(l));
    }
    std::vector<int> got = t.neighbours(static_cast<int>(j));
    std::sort(got.begin(), got.end());
    EXPECT_EQ(got, expected) << "landmark " << j;
    for (const int l : expected) EXPECT_TRUE(t.local(static_cast<int>(j), l));
  }
  std::vector<int> q;
  t.query({75, 75}, 20.0, &q);
  for (std::size_t l = 0; l < t.size(); ++l) {
    const bool inside = (w.map[l].position - Eigen::Vector2d(75, 75)).norm() <= 20.0;
    EXPECT_EQ(std::count(q.begin(), q.end(), static_cast<int>(l)), inside ? 1 : 0);
  }
}

TEST(MapPairTable, SkipsLandmarksThatAreNotFinite) {
  World w = reloc_test::randomMap(5, 20.0, 2.0, 4);
  w.map[2].position.x() = kNaN;
  MapPairTable t;
  t.build(w.map, 16.0);
  EXPECT_EQ(t.size(), 4u);
}

TEST(FitPose, RecoversThePoseWithAConsistentCovariance) {
  const World w = reloc_test::randomMap(30, 40.0, 3.0, 5);
  const Eigen::Vector3d truth(12.0, 17.0, 2.5);
  std::vector<LandmarkId> ids;
  const auto obs = w.observe(truth, 15.0, &ids, /*noise=*/false);
  const auto pts = observedPoints(obs, w.sensor_offset, 15.0);
  ASSERT_GE(pts.size(), 4u);
  std::vector<PointPairing> pairs;
  for (const ObservedPoint& p : pts) pairs.push_back({&p, &w.map[ids[p.input] - 100]});
  const PoseFit f = fitPose(pairs);
  ASSERT_TRUE(f.ok);
  EXPECT_NEAR(reloc_test::positionError(f.pose, truth), 0.0, 1e-6);
  EXPECT_NEAR(reloc_test::headingError(f.pose, truth), 0.0, 1e-8);
  EXPECT_NEAR(f.d2, 0.0, 1e-6);
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(f.covariance);
  EXPECT_GT(es.eigenvalues().minCoeff(), 0.0);
  // Every landmark has sigma 0.1: the position cannot be known better than 0.1 / sqrt(k).
  EXPECT_GT(f.covariance(0, 0), 0.01 / static_cast<double>(pairs.size()) * 0.99);
}

TEST(FitPose, NeedsTwoPairings) {
  const World w = reloc_test::randomMap(3, 20.0, 2.0, 6);
  ObservedPoint p;
  p.p = Eigen::Vector2d(1, 1);
  p.cov = Eigen::Matrix2d::Identity() * 0.01;
  EXPECT_FALSE(fitPose({}).ok);
  EXPECT_FALSE(fitPose({{&p, &w.map[0]}}).ok);
}

}  // namespace test_geometric_constraints
}  // namespace ekf_slam
