// NN + JCBB hybrid (seed 003 section 2.2) on hand-made problems.
#include <gtest/gtest.h>

#include <algorithm>
#include <map>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "association_fixtures.h"
#include "ekf_slam/core/association/nnjcbb.h"
#include "ekf_slam/core/common/chi2.h"

namespace ekf_slam {
namespace test_nnjcbb {

using assoc_test::Scene;

NNJCBB makeHybrid(std::map<std::string, std::string> values = {}) {
  NNJCBB h;
  h.configure(MapParameterSource(std::move(values)));
  return h;
}

TEST(NNJCBB, NoInterferenceKeepsNN) {
  Scene s;
  assoc_test::unambiguousScene(&s);
  NNJCBB h = makeHybrid();
  const AssociationResult r = h.associate(s.context());
  for (int i = 0; i < 6; ++i) EXPECT_EQ(r.landmark[i], s.expectId(i));
  EXPECT_FALSE(h.lastRanJcbb());
  EXPECT_EQ(h.jcbbRuns(), 0u);
  EXPECT_EQ(h.steps(), 1u);
}

TEST(NNJCBB, InterferenceRunsJcbbWithMutualExclusion) {
  Scene s;
  s.pose_cov = assoc_test::poseCov(0.2, 0.2, 0.01);
  s.addLandmark(Eigen::Vector2d(10, 0));
  s.addLandmark(Eigen::Vector2d(4, 6));
  s.build();
  s.observeLandmark(0);
  s.observePoint(Eigen::Vector2d(10.0, 0.3));  // NN would put it on landmark 0 as well
  s.observeLandmark(1);
  NNJCBB h = makeHybrid();
  const AssociationResult r = h.associate(s.context());
  EXPECT_TRUE(h.lastRanJcbb());
  EXPECT_EQ(h.jcbbRuns(), 1u);
  EXPECT_EQ(r.landmark[2], Scene::idOf(1));
  // Landmark 0 is used once, by the observation that truly comes from it (the least D^2 among
  // the two-pairing hypotheses).
  EXPECT_EQ(r.landmark[0], Scene::idOf(0));
  EXPECT_EQ(r.decision[1], Decision::kRejected);
  EXPECT_EQ(h.stepsSinceJcbb(), 0);
}

TEST(NNJCBB, PrefersTheLeastJointDistanceAmongTheLargest) {
  // Observation 0 is a bit off the landmark, observation 1 right on it: plain JCBB keeps the
  // first found (observation 0), the hybrid's optimal criterion takes observation 1.
  Scene s;
  s.pose_cov = assoc_test::poseCov(0.2, 0.2, 0.01);
  s.addLandmark(Eigen::Vector2d(10, 0));
  s.build();
  s.observePoint(Eigen::Vector2d(10.0, 0.25), nullptr, -1);
  s.observeLandmark(0);
  const AssociationContext ctx = s.context();
  ASSERT_LT(ctx.individual(0, 0).mahalanobis, 5.99);
  ASSERT_LT(ctx.individual(1, 0).mahalanobis, ctx.individual(0, 0).mahalanobis);
  NNJCBB h = makeHybrid();
  const AssociationResult r = h.associate(ctx);
  EXPECT_TRUE(h.lastRanJcbb());
  EXPECT_EQ(r.landmark[1], Scene::idOf(0));
  EXPECT_EQ(r.decision[0], Decision::kRejected);
  EXPECT_NEAR(h.lastStats().joint_distance, ctx.individual(1, 0).mahalanobis, 1e-9);

  NNJCBB first = makeHybrid({{"prefer_least_distance", "false"}});
  EXPECT_EQ(first.associate(ctx).landmark[0], Scene::idOf(0));
}

TEST(NNJCBB, InterferenceBelowThresholdIsSettledByMutualExclusion) {
  Scene s;
  assoc_test::unambiguousScene(&s);
  s.observePoint(Eigen::Vector2d(10.0, 5.3));  // competes with observation 0 for landmark 0
  // 2 of 7 paired observations interfere: share 0.286.
  {
    NNJCBB h = makeHybrid({{"interference_threshold", "0.5"}});
    const AssociationResult r = h.associate(s.context());
    EXPECT_FALSE(h.lastRanJcbb());
    for (int i = 0; i < 6; ++i) EXPECT_EQ(r.landmark[i], s.expectId(i));
    EXPECT_EQ(r.decision[6], Decision::kRejected);
  }
  {
    NNJCBB h = makeHybrid({{"interference_threshold", "0.2"}});
    const AssociationResult r = h.associate(s.context());
    EXPECT_TRUE(h.lastRanJcbb());
    for (int i = 0; i < 6; ++i) EXPECT_EQ(r.landmark[i], s.expectId(i));
    EXPECT_EQ(r.decision[6], Decision::kRejected);
  }
}

TEST(NNJCBB, EveryNScansAndReset) {
  Scene s;
  const int decoy = assoc_test::largePoseErrorScene(&s);
  const AssociationContext ctx = s.context();
  NNJCBB h = makeHybrid({{"jcbb_every_n_scans", "3"}});
  // NN's answer does not interfere (the decoy is taken once), so only the schedule brings JCBB
  // in, and only JCBB gets observation 0 right.
  for (int scan = 1; scan <= 7; ++scan) {
    const AssociationResult r = h.associate(ctx);
    const bool jcbb = scan % 3 == 0;
    EXPECT_EQ(h.lastRanJcbb(), jcbb) << scan;
    EXPECT_EQ(r.landmark[0], jcbb ? s.expectId(0) : Scene::idOf(decoy)) << scan;
    for (int i = 1; i < 5; ++i) EXPECT_EQ(r.landmark[i], s.expectId(i));
  }
  EXPECT_EQ(h.steps(), 7u);
  EXPECT_EQ(h.jcbbRuns(), 2u);
  EXPECT_EQ(h.stepsSinceJcbb(), 1);
  h.reset();
  EXPECT_EQ(h.steps(), 0u);
  EXPECT_EQ(h.stepsSinceJcbb(), 0);
  EXPECT_EQ(h.jcbbRuns(), 0u);
  h.associate(ctx);
  h.associate(ctx);
  EXPECT_FALSE(h.lastRanJcbb());
  h.associate(ctx);
  EXPECT_TRUE(h.lastRanJcbb());

  NNJCBB every = makeHybrid({{"jcbb_every_n_scans", "1"}});
  const AssociationResult r = every.associate(ctx);
  for (int i = 0; i < 5; ++i) EXPECT_EQ(r.landmark[i], s.expectId(i));
}

TEST(NNJCBB, ClutterEmptyMapEmptyScanBehind) {
  // Plain, and with JCBB forced at every scan.
  assoc_test::expectEdgeCases([](const Scene& s) { return makeHybrid().associate(s.context()); });
  assoc_test::expectEdgeCases([](const Scene& s) {
    return makeHybrid({{"jcbb_every_n_scans", "1"}}).associate(s.context());
  });
}

TEST(NNJCBB, NeverPairsALandmarkTwiceOnRandomScenes) {
  std::mt19937 rng(99);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  int ran = 0;
  for (int trial = 0; trial < 60; ++trial) {
    Scene s;
    s.pose_cov = assoc_test::poseCov(0.5, 0.5, 0.03);
    for (int j = 0; j < 8; ++j) {
      s.addLandmark(Eigen::Vector2d(5 + 8 * u(rng), -4 + 8 * u(rng)), assoc_test::diag2(0.1, 0.1));
    }
    s.build();
    s.observeAll(30.0, &rng);
    for (int c = 0; c < 3; ++c) s.observePoint(Eigen::Vector2d(5 + 8 * u(rng), -4 + 8 * u(rng)));
    NNJCBB h = makeHybrid();
    const AssociationContext ctx = s.context();
    const AssociationResult r = h.associate(ctx);
    ran += h.lastRanJcbb();
    std::vector<std::pair<int, int>> pairs;
    std::vector<LandmarkId> used;
    for (std::size_t i = 0; i < r.landmark.size(); ++i) {
      if (r.decision[i] != Decision::kPaired) continue;
      EXPECT_EQ(std::count(used.begin(), used.end(), r.landmark[i]), 0);
      used.push_back(r.landmark[i]);
      pairs.emplace_back(static_cast<int>(i), s.ekf.indexOf(r.landmark[i]));
    }
    if (h.lastRanJcbb() && !pairs.empty()) {
      EXPECT_LE(ctx.jointMahalanobis(pairs),
                chi2Quantile(0.95, 2 * static_cast<int>(pairs.size())));
    }
  }
  EXPECT_GT(ran, 10);
}

}  // namespace test_nnjcbb
}  // namespace ekf_slam
