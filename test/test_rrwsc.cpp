// The ekf_slam/RRWSC associator: graph matching then the filter gate, the new-landmark rule for
// unmatched observations, no update from a match the filter cannot accept (prior wrong by 30 m and
// 90 deg), cost independent of landmarks out of reach, parameter errors.
#include <gtest/gtest.h>

#include <map>
#include <random>
#include <string>
#include <vector>

#include "association_fixtures.h"
#include "ekf_slam/core/association/rrwsc.h"
#include "rrwsc_fixtures.h"

namespace ekf_slam {
namespace {

using assoc_test::Scene;

AssociationResult runRrwsc(const Scene& s, RRWSC* assoc = nullptr) {
  RRWSC local;
  RRWSC& a = assoc != nullptr ? *assoc : local;
  a.configure(MapParameterSource());
  return a.associate(s.context());
}

TEST(RRWSC, UnambiguousPairs) {
  std::mt19937 rng(8);
  for (int trial = 0; trial < 20; ++trial) {
    Scene s;
    assoc_test::unambiguousScene(&s, trial == 0 ? nullptr : &rng);
    const AssociationResult r = runRrwsc(s);
    for (int i = 0; i < 6; ++i) EXPECT_EQ(r.landmark[i], s.expectId(i)) << trial;
  }
}

TEST(RRWSC, ClutterEmptyMapEmptyScanBehind) {
  assoc_test::expectEdgeCases([](const Scene& s) { return runRrwsc(s); });
}

TEST(RRWSC, ThePapersWholeMapViewWithOcclusion) {
  // 40 landmarks >= 10 m apart, all in view but 8, measurement noise 0.1 m and 3 deg (seed 004).
  Scene s;
  s.est_pose = s.true_pose = Eigen::Vector3d(-20.0, 10.0, 0.7);
  s.pose_cov = assoc_test::poseCov(0.3, 0.3, deg2rad(1.0));
  s.R = assoc_test::diag2(0.1, deg2rad(3.0));
  for (const auto& p : rrwsc_test::randomMap(40, 100.0, 10.0, 21)) {
    s.addLandmark(p, assoc_test::diag2(0.3, 0.3));
  }
  s.build();
  std::mt19937 rng(4);
  for (int j = 8; j < 40; ++j) s.observeLandmark(j, &rng);
  RRWSC rrwsc;
  const AssociationResult r = runRrwsc(s, &rrwsc);
  int right = 0;
  for (std::size_t i = 0; i < r.landmark.size(); ++i) {
    EXPECT_TRUE(r.landmark[i] == kNoLandmark || r.landmark[i] == s.expectId(i)) << i;
    right += r.landmark[i] == s.expectId(i);
  }
  EXPECT_GE(right, 31);
}

TEST(RRWSC, MatchesThePriorCannotExplainAreNotUsed) {
  // The filter believes the robot 30 m and 90 deg away from the truth: the graph still matches
  // the scan, but the gate refuses every match, and nothing becomes a (duplicate) new landmark.
  Scene s;
  s.true_pose = Eigen::Vector3d(0.0, 0.0, 0.2);
  s.est_pose = Eigen::Vector3d(30.0, 0.0, 0.2 + M_PI / 2);
  s.pose_cov = assoc_test::poseCov(0.5, 0.5, deg2rad(2.0));
  s.R = assoc_test::diag2(0.1, deg2rad(1.0));
  for (const auto& p : rrwsc_test::randomMap(30, 60.0, 10.0, 5)) s.addLandmark(p);
  s.build();
  std::mt19937 rng(9);
  s.observeAll(1000.0, &rng);
  // The map graph must reach the landmarks seen from the true pose: a margin beyond the 30 m.
  // Pure graph matching (position_weight 0): with the default weight the wrong prior pulls some
  // matches onto landmarks it happens to predict there, which then pass the gate like any
  // gated associator's would.
  RRWSC rrwsc;
  rrwsc.configure(MapParameterSource(
      std::map<std::string, std::string>{{"candidate_margin", "40"}, {"position_weight", "0"}}));
  const AssociationResult r = rrwsc.associate(s.context());
  for (std::size_t i = 0; i < r.decision.size(); ++i) {
    EXPECT_EQ(r.decision[i], Decision::kRejected) << i;
  }
  EXPECT_EQ(rrwsc.stats().matched, 30u);
  EXPECT_EQ(rrwsc.stats().incompatible, 30u);
}

TEST(RRWSC, CostDoesNotGrowWithLandmarksOutOfReach) {
  // The same scene with and without 500 landmarks far away: the same number of evaluations.
  std::size_t evaluations[2] = {0, 0};
  for (int far = 0; far < 2; ++far) {
    Scene s;
    assoc_test::unambiguousScene(&s);
    if (far == 1) {
      Scene big;
      big.est_pose = big.true_pose = s.true_pose;
      big.pose_cov = s.pose_cov;
      for (const auto& p : s.landmarks) big.addLandmark(p);
      for (int k = 0; k < 500; ++k)
        big.addLandmark(Eigen::Vector2d(1000.0 + 10.0 * (k % 25), 10.0 * (k / 25)));
      big.build();
      big.observeAll(30.0);
      const AssociationContext ctx = big.context();
      RRWSC rrwsc;
      rrwsc.configure(MapParameterSource());
      const AssociationResult r = rrwsc.associate(ctx);
      for (int i = 0; i < 6; ++i) EXPECT_EQ(r.landmark[i], big.expectId(i));
      evaluations[far] = ctx.evaluations();
    } else {
      const AssociationContext ctx = s.context();
      RRWSC rrwsc;
      rrwsc.configure(MapParameterSource());
      rrwsc.associate(ctx);
      evaluations[far] = ctx.evaluations();
    }
  }
  EXPECT_GT(evaluations[0], 0u);
  EXPECT_EQ(evaluations[0], evaluations[1]);
}

TEST(RRWSC, BadParametersNameTheParameter) {
  RRWSC rrwsc;
  for (const auto& [name, value] :
       std::vector<std::pair<std::string, std::string>>{{"alpha", "1.5"},
                                                        {"beta", "0"},
                                                        {"max_iterations", "0"},
                                                        {"edge_sigma", "-1"},
                                                        {"context_max_radius", "1"},
                                                        {"individual_probability", "0.99999"}}) {
    try {
      rrwsc.configure(MapParameterSource(std::map<std::string, std::string>{{name, value}}));
      FAIL() << name << " = " << value << " accepted";
    } catch (const ParameterError& e) {
      EXPECT_NE(std::string(e.what()).find(name), std::string::npos) << e.what();
    }
  }
  rrwsc.configure(MapParameterSource(
      std::map<std::string, std::string>{{"position_weight", "0"}, {"beta", "10"}}));
  EXPECT_EQ(rrwsc.params().position_weight, 0.0);
  EXPECT_EQ(rrwsc.params().walk.beta, 10.0);
  EXPECT_NEAR(rrwsc.gating().individual_probability, 0.999, 1e-12);
}

}  // namespace
}  // namespace ekf_slam

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
