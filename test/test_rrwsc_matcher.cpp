// RRW&SC graph matching: a scan matched to the map without a usable prior (the prior is wrong by
// 30 m and 90 deg), under occlusion and clutter, and the position term resolving a symmetric map.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "ekf_slam/core/graph_matching/rrwsc_matcher.h"
#include "rrwsc_fixtures.h"

namespace ekf_slam {
namespace test_rrwsc_matcher {

// The scan as points in the sensor frame with covariances G R G^T.
MatchInput inputOf(const rrwsc_test::Scan& scan, const std::vector<Eigen::Vector2d>& map,
                   double map_sigma) {
  MatchInput in;
  setObservedPoints(scan.observations, &in);
  in.landmarks = map;
  in.landmark_cov.assign(map.size(), map_sigma * map_sigma * Eigen::Matrix2d::Identity());
  return in;
}

// M_ij of each observation against each landmark seen from the pose `prior` (sensor pose) with
// an isotropic position uncertainty sigma.
Eigen::MatrixXd mahalanobisFrom(const MatchInput& in, const Eigen::Vector3d& prior, double sigma) {
  Eigen::MatrixXd m(in.observed.size(), in.landmarks.size());
  const Eigen::Matrix2d rot = Eigen::Rotation2Dd(prior.z()).toRotationMatrix();
  for (std::size_t i = 0; i < in.observed.size(); ++i) {
    const Eigen::Vector2d world = rot * in.observed[i] + prior.head<2>();
    const Eigen::Matrix2d cov =
        rot * in.observed_cov[i] * rot.transpose() + sigma * sigma * Eigen::Matrix2d::Identity();
    for (std::size_t j = 0; j < in.landmarks.size(); ++j) {
      const Eigen::Vector2d e = world - in.landmarks[j];
      m(i, j) = e.dot(cov.inverse() * e);
    }
  }
  return m;
}

int correct(const std::vector<int>& match, const std::vector<int>& truth, int* wrong) {
  int ok = 0;
  *wrong = 0;
  for (std::size_t i = 0; i < match.size(); ++i) {
    if (truth[i] >= 0 && match[i] == truth[i]) ++ok;
    if (truth[i] >= 0 && match[i] >= 0 && match[i] != truth[i]) ++*wrong;
  }
  return ok;
}

TEST(RrwscMatcher, MatchesWhenThePriorIsWrongBy30mAnd90Degrees) {
  const auto map = rrwsc_test::randomMap(40, 100.0, 10.0, 7);
  const Eigen::Vector3d sensor(-20.0, 35.0, 0.4);
  const auto scan = rrwsc_test::scanOf(map, sensor, {0.1, deg2rad(1.0)}, 3);
  MatchInput in = inputOf(scan, map, 0.2);
  const Eigen::Vector3d wrong_prior(sensor.x() + 30.0, sensor.y(), sensor.z() + M_PI / 2);
  in.mahalanobis = mahalanobisFrom(in, wrong_prior, 1.0);
  RrwscMatcher matcher;
  std::vector<int> match;
  matcher.match(in, RrwscParams(), &match);  // position_weight 0: pure graph matching
  int wrong = 0;
  EXPECT_EQ(correct(match, scan.truth, &wrong), 40);
  EXPECT_EQ(wrong, 0);
  EXPECT_LT(matcher.stats().iterations, 300);
  // Sparse: far fewer affinity entries than candidates squared.
  EXPECT_LT(matcher.stats().entries,
            static_cast<std::size_t>(matcher.stats().candidates) * matcher.stats().candidates / 4);
}

TEST(RrwscMatcher, MatchesWithThePapersNoiseOcclusionAndClutter) {
  const auto map = rrwsc_test::randomMap(40, 100.0, 10.0, 11);
  const Eigen::Vector3d sensor(10.0, -5.0, -2.0);
  const auto scan =
      rrwsc_test::scanOf(map, sensor, {0.1, deg2rad(3.0)}, 5, {1, 4, 9, 16, 25, 36, 2, 3, 5, 7}, 3);
  // Shape contexts over the whole 200 m map (as sim::associatorParametersFor sets them for the
  // seed 004 worlds); no prior at all.
  RrwscParams p;
  p.context.min_radius = 5.0;
  p.context.max_radius = 300.0;
  RrwscMatcher matcher;
  std::vector<int> match;
  matcher.match(inputOf(scan, map, 0.5), p, &match);
  int wrong = 0;
  EXPECT_GE(correct(match, scan.truth, &wrong), 29);  // of 30 visible landmarks
  EXPECT_LE(wrong, 1);
  // The default 100 m context sees too little of this sparse map: more mistakes.
  matcher.match(inputOf(scan, map, 0.5), RrwscParams(), &match);
  EXPECT_LT(correct(match, scan.truth, &wrong), 29);
}

TEST(RrwscMatcher, PositionTermResolvesASymmetricMap) {
  // A square: every rotation by 90 deg fits the graph equally well; the prior picks one.
  const std::vector<Eigen::Vector2d> map = {{0, 0}, {20, 0}, {20, 20}, {0, 20}};
  const Eigen::Vector3d sensor(10.0, 10.0, 0.3);
  const auto scan = rrwsc_test::scanOf(map, sensor, {0.05, deg2rad(0.5)}, 1);
  MatchInput in = inputOf(scan, map, 0.1);
  in.mahalanobis = mahalanobisFrom(in, sensor, 1.0);
  RrwscParams p;
  p.position_weight = 1.0;
  RrwscMatcher matcher;
  std::vector<int> match;
  matcher.match(in, p, &match);
  EXPECT_EQ(match, scan.truth);
}

TEST(RrwscMatcher, EmptyInputsGiveNoMatch) {
  RrwscMatcher matcher;
  std::vector<int> match;
  MatchInput in;
  matcher.match(in, RrwscParams(), &match);
  EXPECT_TRUE(match.empty());
  in.observed = {{1, 0}};
  in.observed_cov = {Eigen::Matrix2d::Identity()};
  matcher.match(in, RrwscParams(), &match);
  EXPECT_EQ(match, (std::vector<int>{-1}));
}

}  // namespace test_rrwsc_matcher
}  // namespace ekf_slam
