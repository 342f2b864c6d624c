// NN / ICNN (seed 000 eq. 4-5) on hand-made problems.
#include <gtest/gtest.h>

#include <random>
#include <vector>

#include "association_fixtures.h"
#include "ekf_slam/core/association/nn.h"
#include "ekf_slam/core/common/chi2.h"

namespace ekf_slam {
namespace test_nn {

using assoc_test::Scene;

AssociationResult runNN(const Scene& s, bool exclusive = false) {
  NN nn;
  MapParameterSource params;
  if (exclusive) params.set("mutual_exclusion", "true");
  nn.configure(params);
  return nn.associate(s.context());
}

TEST(NN, UnambiguousPairs) {
  std::mt19937 rng(7);
  for (int trial = 0; trial < 20; ++trial) {
    Scene s;
    assoc_test::unambiguousScene(&s, trial == 0 ? nullptr : &rng);
    ASSERT_EQ(s.observations.size(), 6u);
    const AssociationResult r = runNN(s);
    ASSERT_EQ(r.decision.size(), 6u);
    for (int i = 0; i < 6; ++i) {
      EXPECT_EQ(r.decision[i], Decision::kPaired);
      EXPECT_EQ(r.landmark[i], s.expectId(i));
    }
    EXPECT_TRUE(r.remove.empty());
  }
}

TEST(NN, TwoObservationsCompeteForOneLandmark) {
  // One landmark; a second return 0.3 m beside it (e.g. a pole next to the tree).
  Scene s;
  s.pose_cov = assoc_test::poseCov(0.2, 0.2, 0.01);
  s.addLandmark(Eigen::Vector2d(10, 0));
  s.build();
  s.observeLandmark(0);
  s.observePoint(Eigen::Vector2d(10.0, 0.3));
  {
    // Plain NN (the papers' baseline) lets the interference happen: both take landmark 0.
    const AssociationResult r = runNN(s);
    EXPECT_EQ(r.landmark[0], Scene::idOf(0));
    EXPECT_EQ(r.landmark[1], Scene::idOf(0));
  }
  {
    // With mutual exclusion the closer observation keeps it; the other is too close to the
    // landmark to be a new one, so it is rejected.
    const AssociationResult r = runNN(s, true);
    EXPECT_EQ(r.landmark[0], Scene::idOf(0));
    EXPECT_EQ(r.decision[1], Decision::kRejected);
    EXPECT_EQ(r.landmark[1], kNoLandmark);
  }
}

TEST(NN, MutualExclusionLoserTakesItsNextChoice) {
  Scene s;
  s.pose_cov = assoc_test::poseCov(0.2, 0.2, 0.01);
  s.addLandmark(Eigen::Vector2d(10, 0));
  s.addLandmark(Eigen::Vector2d(10, 0.8));
  s.build();
  s.observeLandmark(0);
  s.observePoint(Eigen::Vector2d(10.0, 0.35));  // nearer landmark 0, within the gate of 1 too
  const AssociationContext ctx = s.context();
  ASSERT_LT(ctx.individual(1, 1).mahalanobis, 5.99);
  const AssociationResult plain = runNN(s);
  EXPECT_EQ(plain.landmark[1], Scene::idOf(0));
  const AssociationResult r = runNN(s, true);
  EXPECT_EQ(r.landmark[0], Scene::idOf(0));
  EXPECT_EQ(r.landmark[1], Scene::idOf(1));
}

TEST(NN, ObservationBetweenTwoLandmarksUsesTheLikelihoodScore) {
  // Equidistant from two landmarks; landmark 1 is much less certain, so it has the smaller M_ij
  // but the larger ln|S_ij|: eq. 5 (M + ln|S|) prefers landmark 0, plain M would take 1.
  Scene s;
  s.pose_cov = assoc_test::poseCov(0.05, 0.05, 0.005);
  s.R = assoc_test::diag2(0.05, 0.005);
  s.addLandmark(Eigen::Vector2d(10, -0.2), assoc_test::diag2(0.2, 0.2));
  s.addLandmark(Eigen::Vector2d(10, 0.2), assoc_test::diag2(0.4, 0.4));
  s.build();
  s.observePoint(Eigen::Vector2d(10, 0.0));
  const AssociationContext ctx = s.context();
  const auto a = ctx.individual(0, 0);
  const auto b = ctx.individual(0, 1);
  ASSERT_LT(a.mahalanobis, 5.99);
  ASSERT_LT(b.mahalanobis, a.mahalanobis);
  ASSERT_LT(a.mahalanobis + a.log_det_S, b.mahalanobis + b.log_det_S);
  const AssociationResult r = runNN(s);
  EXPECT_EQ(r.landmark[0], Scene::idOf(0));
  EXPECT_EQ(nearestNeighbour(ctx, 0, {0, 1}, 5.99), 0);
}

TEST(NN, ClutterIsNewFarAwayAndRejectedNearALandmark) {
  Scene s;
  assoc_test::clutterScene(&s);
  const AssociationContext ctx = s.context();
  const double m2 = ctx.individual(2, 0).mahalanobis;
  ASSERT_GT(m2, 5.99);
  ASSERT_LT(m2, 18.42);
  const AssociationResult r = runNN(s);
  EXPECT_EQ(r.decision[0], Decision::kPaired);
  EXPECT_EQ(r.landmark[0], Scene::idOf(0));
  EXPECT_EQ(r.decision[1], Decision::kNew);
  EXPECT_EQ(r.landmark[1], kNoLandmark);
  EXPECT_EQ(r.decision[2], Decision::kRejected);
}

TEST(NN, EmptyMapMakesEverythingNew) {
  Scene s;
  s.build();
  s.observePoint(Eigen::Vector2d(5, 1));
  s.observePoint(Eigen::Vector2d(7, -3));
  const AssociationResult r = runNN(s);
  ASSERT_EQ(r.decision.size(), 2u);
  EXPECT_EQ(r.decision[0], Decision::kNew);
  EXPECT_EQ(r.decision[1], Decision::kNew);
}

TEST(NN, EmptyScan) {
  Scene s;
  assoc_test::unambiguousScene(&s);
  s.observations.clear();
  s.truth.clear();
  const AssociationResult r = runNN(s);
  EXPECT_TRUE(r.decision.empty());
  EXPECT_TRUE(r.landmark.empty());
}

TEST(NN, LandmarksBehindTheRobot) {
  Scene s;
  assoc_test::behindScene(&s);
  const AssociationResult r = runNN(s);
  for (int i = 0; i < 3; ++i) EXPECT_EQ(r.landmark[i], s.expectId(i)) << i;
}

TEST(NN, LargePoseErrorFoolsNN) {
  // The baseline's known failure (JCBB's test shows the joint test fixes it).
  Scene s;
  const int decoy = assoc_test::largePoseErrorScene(&s);
  const AssociationResult r = runNN(s);
  EXPECT_EQ(r.landmark[0], Scene::idOf(decoy));
  for (int i = 1; i < 5; ++i) EXPECT_EQ(r.landmark[i], s.expectId(i)) << i;
}

TEST(NN, NearestNeighbourHelperSkipsTakenLandmarks) {
  Scene s;
  s.pose_cov = assoc_test::poseCov(0.2, 0.2, 0.01);
  s.addLandmark(Eigen::Vector2d(10, 0));
  s.addLandmark(Eigen::Vector2d(10, 0.8));
  s.addLandmark(Eigen::Vector2d(30, 1.0));
  s.build();
  s.observePoint(Eigen::Vector2d(10.0, 0.35));
  const AssociationContext ctx = s.context();
  const std::vector<int> cand = ctx.candidateLandmarks(5.0);
  AssociationContext::Individual best;
  EXPECT_EQ(nearestNeighbour(ctx, 0, cand, 5.99, nullptr, &best), 0);
  EXPECT_NEAR(best.mahalanobis, ctx.individual(0, 0).mahalanobis, 1e-12);
  std::vector<char> taken(3, 0);
  taken[0] = 1;
  EXPECT_EQ(nearestNeighbour(ctx, 0, cand, 5.99, &taken), 1);
  taken[1] = 1;
  EXPECT_EQ(nearestNeighbour(ctx, 0, cand, 5.99, &taken), -1);
  EXPECT_EQ(nearestNeighbour(ctx, 0, cand, 1e-6), -1);  // nothing inside a tiny gate
}

TEST(NN, AgreesWithTheHelperOnRandomScenes) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(-12.0, 12.0);
  for (int trial = 0; trial < 30; ++trial) {
    Scene s;
    s.pose_cov = assoc_test::poseCov(0.5, 0.5, 0.05);
    s.true_pose = Eigen::Vector3d(0.3, -0.2, 0.03);
    for (int j = 0; j < 12; ++j) s.addLandmark(Eigen::Vector2d(u(rng), u(rng)));
    s.build();
    s.observeAll(10.0, &rng);
    for (int c = 0; c < 3; ++c) s.observePoint(Eigen::Vector2d(u(rng), u(rng)), &rng);
    const AssociationContext ctx = s.context();
    const AssociationResult r = runNN(s);
    const std::vector<int> cand = ctx.candidateLandmarks(5.0);
    for (std::size_t i = 0; i < s.observations.size(); ++i) {
      const int j = nearestNeighbour(ctx, static_cast<int>(i), cand, chi2Quantile(0.95, 2));
      EXPECT_EQ(r.landmark[i], j >= 0 ? ctx.landmarkId(j) : kNoLandmark);
    }
  }
}

}  // namespace test_nn
}  // namespace ekf_slam
