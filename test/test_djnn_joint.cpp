// DJNN's joint decision at loop closures (docs/djnn.md, "A joint decision at loop closures"): the
// branch and bound finds the joint maximum-likelihood assignment (checked against enumeration), a
// shifted scan that one unambiguous marker contradicts loses, a near-tie is held undecided (no
// pairing, no tentative feature), and scans on landmarks paired recently are left to NN.
#include <cmath>
#include <functional>
#include <map>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "association_fixtures.h"
#include "djnn_fixtures.h"
#include "ekf_slam/core/association/djnn/djnn.h"
#include "ekf_slam/core/association/djnn/unmapped_returns.h"
#include "ekf_slam/core/association/joint_ml.h"
#include "ekf_slam/core/common/angles.h"

namespace ekf_slam {
namespace test_djnn_joint {

using assoc_test::makeDjnn;
using assoc_test::Scene;

const std::map<std::string, std::string> kJoint = {{"loop_closure_age", "30"},
                                                   {"landmark_density", "0.3"}};

// A row of markers 0.8 m apart; the pose estimate is 1 m uncertain along it.
void periodicRow(Scene* s, std::vector<int>* row) {
  s->pose_cov = assoc_test::poseCov(1.0, 0.05, 0.005);
  s->R = assoc_test::diag2(0.03, deg2rad(1));
  for (int k = 0; k < 6; ++k) row->push_back(s->addLandmark({2.0 + 0.8 * k, 0.5}));
}

TEST(JointMaximumLikelihood, BranchAndBoundFindsTheEnumeratedOptimum) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int trial = 0; trial < 20; ++trial) {
    Scene s;
    s.pose_cov = assoc_test::poseCov(0.6, 0.6, 0.05);
    for (int j = 0; j < 8; ++j) s.addLandmark({4.0 + 2.0 * u(rng), 2.0 * u(rng)});
    s.true_pose = Eigen::Vector3d(0.5 * u(rng), 0.5 * u(rng), 0.03 * u(rng));
    s.build();
    for (int j = 0; j < 4; ++j) s.observeLandmark(j, &rng);
    s.observePoint({4.0 + 2.0 * u(rng), 2.0 * u(rng)}, &rng);
    const AssociationContext ctx = s.context(0);
    JointMlProblem problem;
    problem.null_cost = -2.0 * std::log(0.3);
    for (int i = 0; i < 5; ++i) {
      problem.obs.push_back(i);
      problem.candidates.emplace_back();
      for (int j = 0; j < 8; ++j) {
        if (ctx.individual(i, j).mahalanobis <= 13.8) problem.candidates.back().push_back(j);
      }
    }
    const JointMlDecision d = jointMaximumLikelihood(ctx, problem, 6.0);
    ASSERT_TRUE(d.complete);
    // Enumeration of every one-to-one hypothesis, each costed from scratch (the search extends
    // its factor one pairing at a time): the best, and per observation the best that decides it
    // otherwise than the search's best.
    double best = 1e300;
    std::vector<double> other(5, 1e300);
    std::vector<int> h(5, -1);
    std::function<void(int)> all = [&](int k) {
      if (k == 5) {
        std::vector<std::pair<int, int>> pairs;
        double nulls = 0.0;
        for (int i = 0; i < 5; ++i) {
          if (h[i] < 0) {
            nulls += unmappedCostAt(problem.null_cost, ctx.observations()[i]);
          } else {
            pairs.emplace_back(i, h[i]);
          }
        }
        const double cost = jointInnovationCost(ctx, pairs) +
                            2.0 * std::log(2.0 * M_PI) * static_cast<double>(pairs.size()) + nulls;
        best = std::min(best, cost);
        for (int i = 0; i < 5; ++i) {
          if (h[i] != d.best[i]) other[i] = std::min(other[i], cost);
        }
        return;
      }
      h[k] = -1;
      all(k + 1);
      for (int j : problem.candidates[k]) {
        bool used = false;
        for (int i = 0; i < k; ++i) used = used || h[i] == j;
        if (used) continue;
        h[k] = j;
        all(k + 1);
      }
      h[k] = -1;
    };
    all(0);
    EXPECT_NEAR(d.best_cost, best, 1e-9) << trial;
    for (std::size_t k = 0; k < 5; ++k) {
      EXPECT_GE(d.alternative_cost[k], d.best_cost) << trial;
      // Searched within the margin only: beyond it "none" (infinite).
      if (other[k] < d.best_cost + 6.0) {
        EXPECT_NEAR(d.alternative_cost[k], other[k], 1e-9) << trial << " " << k;
      } else {
        EXPECT_GE(d.alternative_cost[k], d.best_cost + 6.0) << trial << " " << k;
      }
    }
  }
}

// An extra option's own cost (JointMlExtra::cost, DJNN's held_birth_cost) is charged: the same
// pairing offered as a landmark and as an extra option ties at no cost (both undecided within the
// margin) and is decided for the landmark once the option costs more than the margin.
TEST(JointMaximumLikelihood, ExtraOptionsPayTheirCost) {
  Scene s;
  s.pose_cov = assoc_test::poseCov(0.05, 0.05, 0.005);
  s.R = assoc_test::diag2(0.03, deg2rad(1));
  const int j = s.addLandmark({3.0, 0.5});
  s.build();
  s.observeLandmark(j);
  const AssociationContext ctx = s.context(0);
  for (const double cost : {0.0, 4.0, 7.0}) {
    JointMlProblem problem;
    problem.null_cost = -2.0 * std::log(0.3);
    problem.obs = {0};
    problem.candidates = {{j}};
    problem.extra = {{JointMlExtra{0, j, 0, cost}}};
    const JointMlDecision d = jointMaximumLikelihood(ctx, problem, 6.0);
    ASSERT_TRUE(d.complete);
    EXPECT_EQ(d.best[0], j) << cost;
    if (cost < 6.0) {
      EXPECT_NEAR(d.alternative_cost[0], d.best_cost + cost, 1e-9) << cost;
    } else {
      EXPECT_TRUE(std::isinf(d.alternative_cost[0])) << cost;  // nothing within the margin
    }
  }
}

// Each entry's own "not in the map" cost (JointMlProblem::null_costs, DJNN's landmark_spacing)
// replaces null_cost for that entry alone: a pairing that beats the common null by less than the
// margin is held, one whose own null is dearer is decided; a cheap own null decides "not in the
// map".
TEST(JointMaximumLikelihood, PerEntryNullCostsAreCharged) {
  Scene s;
  s.pose_cov = assoc_test::poseCov(0.05, 0.05, 0.005);
  s.R = assoc_test::diag2(0.03, deg2rad(1));
  const int a = s.addLandmark({3.0, 0.5});
  const int b = s.addLandmark({3.0, -1.5});
  s.build();
  s.observeLandmark(a);
  s.observeLandmark(b);
  const AssociationContext ctx = s.context(0);
  const double pair_a = ctx.individual(0, a).log_det_S + 2.0 * std::log(2.0 * M_PI);
  JointMlProblem problem;
  problem.obs = {0, 1};
  problem.candidates = {{a}, {b}};
  problem.null_cost = pair_a + 3.0;  // within the margin of the pairing: held
  JointMlDecision d = jointMaximumLikelihood(ctx, problem, 6.0);
  ASSERT_TRUE(d.complete);
  EXPECT_LT(d.alternative_cost[0], d.best_cost + 6.0);
  problem.null_costs = {pair_a + 10.0, problem.null_cost};  // observation 0's own, dearer
  d = jointMaximumLikelihood(ctx, problem, 6.0);
  ASSERT_TRUE(d.complete);
  EXPECT_EQ(d.best[0], a);
  EXPECT_GE(d.alternative_cost[0], d.best_cost + 6.0);
  EXPECT_LT(d.alternative_cost[1], d.best_cost + 6.0);      // observation 1 keeps the common one
  problem.null_costs = {pair_a - 10.0, problem.null_cost};  // cheap: not in the map
  d = jointMaximumLikelihood(ctx, problem, 6.0);
  ASSERT_TRUE(d.complete);
  EXPECT_EQ(d.best[0], -1);
}

// "Not in the map" is a density per m^2 of the plane; a pairing's likelihood is a density in the
// return's measurement space. For a range-bearing return at range r the plane's r dr dphi makes
// that density r times the planar one; a Cartesian return's is the planar one.
TEST(JointMaximumLikelihood, NotInTheMapIsADensityInTheReturnsMeasurementSpace) {
  Observation o;
  o.z = Eigen::Vector2d(28.0, 0.3);
  o.kind = MeasurementKind::kRangeBearing;
  EXPECT_NEAR(unmappedCostAt(5.0, o), 5.0 - 2.0 * std::log(28.0), 1e-12);
  o.z = Eigen::Vector2d(0.0, 0.3);  // at the sensor itself: finite
  EXPECT_TRUE(std::isfinite(unmappedCostAt(5.0, o)));
  o.kind = MeasurementKind::kCartesian;
  o.z = Eigen::Vector2d(28.0, 0.3);
  EXPECT_EQ(unmappedCostAt(5.0, o), 5.0);

  // A return at 28 m a little off a landmark, with "not in the map" 6 + ln 28 dearer per m^2
  // than the pairing: in the plane's units the pairing would pass the margin (as it did until
  // 6 Dec 2026, aekf seed 76's wrong closure); in the return's, the null is 2 ln 28 cheaper and
  // within the margin: held.
  Scene s;
  s.pose_cov = assoc_test::poseCov(1.0, 1.0, 0.01);
  s.R = assoc_test::diag2(0.3, deg2rad(1));
  const int j = s.addLandmark({28.0, 0.0});
  s.build();
  s.observePoint({28.0, 1.5});
  const AssociationContext ctx = s.context(0);
  const AssociationContext::Individual ind = ctx.individual(0, j);
  const double pair = ind.mahalanobis + ind.log_det_S + 2.0 * std::log(2.0 * M_PI);
  JointMlProblem problem;
  problem.obs = {0};
  problem.candidates = {{j}};
  problem.null_cost = pair + 6.0 + std::log(28.0);
  const JointMlDecision d = jointMaximumLikelihood(ctx, problem, 6.0);
  ASSERT_TRUE(d.complete);
  EXPECT_EQ(d.best[0], j);
  EXPECT_NEAR(d.alternative_cost[0] - d.best_cost, 6.0 - std::log(28.0), 0.05);
  EXPECT_LT(d.alternative_cost[0], d.best_cost + 6.0);  // held by the joint decision
}

// UnmappedReturns measures "not in the map" where the map is: the returns left unpaired (within
// range) in scans that paired any, per m^2 of the sensor region, shrunk toward the prior with one
// region's weight, and never above the prior (the density of all landmarks plus clutter).
TEST(DJNNJoint, UnmappedDensityIsMeasuredWhereTheMapIs) {
  Scene s;
  const int j = s.addLandmark({5.0, 0.0});
  s.build();
  s.observeLandmark(j);
  s.observePoint({6.0, 2.0});   // unpaired, in range
  s.observePoint({40.0, 0.0});  // unpaired, beyond the range: not counted
  const AssociationContext ctx = s.context(0);
  LocalScan scan;
  scan.assign = {0, -1, -1};
  for (const bool on : {true, false}) {
    const MapParameterSource params(
        std::map<std::string, std::string>{{"measure_unmapped_density", on ? "true" : "false"}});
    UnmappedReturns u;
    u.read(ParameterReader(params));
    u.configure(100.0);
    EXPECT_DOUBLE_EQ(u.density(0.1), 0.1);  // nothing measured yet: the prior
    for (int k = 0; k < 9; ++k) u.observe(ctx, scan, 30.0);
    // 9 unpaired over 9 regions of 100 m^2, and one region at the prior: 19 / 1000.
    EXPECT_NEAR(u.density(0.1), on ? 0.019 : 0.1, 1e-12) << on;
    LocalScan lost = scan;
    lost.assign = {-1, -1, -1};  // paired nothing: new ground or a lost robot, not counted
    for (int k = 0; k < 5; ++k) u.observe(ctx, lost, 30.0);
    EXPECT_NEAR(u.density(0.1), on ? 0.019 : 0.1, 1e-12) << on;
    EXPECT_NEAR(u.density(0.002), 0.002, 1e-12) << on;  // measured (9.2 / 1000) above the prior
    u.reset();
    EXPECT_DOUBLE_EQ(u.density(0.1), 0.1);
  }
}

// A landmark revisited with the pose known to centimetres, its observation a little off (D^2 of
// about 7, the 97th percentile): against "an unmapped landmark just there" (density 0.3 per m^2)
// the pairing is less than the margin likelier and is held. Landmarks at least 0.8 m apart leave
// only clutter as "not in the map" there: paired. With the pose uncertain by a metre the source
// may lie a spacing away, and landmark_spacing changes nothing.
TEST(DJNNJoint, LandmarkSpacingLeavesOnlyClutterNearALandmark) {
  for (const double pose_sigma : {0.03, 1.0}) {
    for (const bool spacing : {false, true}) {
      Scene s;
      s.pose_cov = assoc_test::poseCov(pose_sigma, 0.03, 0.003);
      s.R = assoc_test::diag2(0.03, deg2rad(1));
      const int j = s.addLandmark({3.0, 0.5});
      s.build();
      std::map<std::string, std::string> p = kJoint;
      p["clutter_density"] = "0.02";
      p["individual_probability"] = "0.999";
      p["ambiguity_probability"] = "0.999";
      if (spacing) p["landmark_spacing"] = "0.8";
      DJNN d = makeDjnn(p);
      // Off along the line of sight: D^2 = 7.
      s.observeLandmark(j);
      const double z0 = s.observations[0].z(0);
      s.observations[0].z(0) = z0 + 0.1;
      const double m1 = s.context(0).individual(0, j).mahalanobis;
      s.observations[0].z(0) = z0 + 0.1 * std::sqrt(7.0 / m1);
      const double m = s.context(0).individual(0, j).mahalanobis;
      ASSERT_GT(m, 6.0);
      ASSERT_LT(m, 8.0);
      const AssociationResult r = d.associate(s.context(0));
      EXPECT_EQ(d.stats().joint_scans, 1u);
      const bool paired = r.decision[0] == Decision::kPaired && r.landmark[0] == Scene::idOf(j);
      EXPECT_EQ(paired, spacing && pose_sigma < 0.5) << pose_sigma << " " << spacing;
    }
  }
}

// Two landmarks are never closer than landmark_spacing. A feature seen scan after scan 0.25 m from
// a map landmark while the pose is known to 2 cm (far outside the landmark's gate, as after a
// large correction that left the pose over-confident) is that landmark seen off, or clutter: it
// stays tentative rather than becoming a duplicate. One 1.5 m away is admitted either way.
TEST(DJNNJoint, NoLandmarkIsAdmittedWithinTheSpacingOfAnother) {
  for (const bool spacing : {false, true}) {
    Scene s;
    s.pose_cov = assoc_test::poseCov(0.02, 0.02, 0.002);
    s.R = assoc_test::diag2(0.03, deg2rad(1));
    const int j = s.addLandmark({3.0, 0.5}, assoc_test::diag2(0.02, 0.02));
    s.build();
    s.observePoint({3.0, 0.75});
    s.observePoint({3.0, -1.0});
    ASSERT_GT(s.context(0).individual(0, j).mahalanobis, 16.0);
    std::map<std::string, std::string> p = {{"admit_evidence", "3"}, {"clutter_density", "0.02"}};
    if (spacing) p["landmark_spacing"] = "0.5";
    DJNN d = makeDjnn(p);
    bool near_admitted = false, far_admitted = false;
    for (int k = 0; k < 10; ++k) {
      const AssociationResult r = d.associate(s.context(0.2 * k));
      near_admitted = near_admitted || r.decision[0] == Decision::kNew;
      far_admitted = far_admitted || r.decision[1] == Decision::kNew;
    }
    EXPECT_EQ(near_admitted, !spacing);
    EXPECT_TRUE(far_admitted);
    EXPECT_EQ(d.stats().spacing_refused > 0, spacing);
  }
}

// The pose is off by one spacing: NN pairs the row one marker along. A marker off the row (the
// corridor's corner) is seen too; the shifted hypothesis must leave it out of the map (or pair it
// 0.8 m off given the row), so the true assignment is far likelier and is taken: at once by a
// per-scan margin, and on the next scan's evidence by the closure's sum (one scan's lead of 8.5
// is less than closure_margin).
TEST(DJNNJoint, ShiftedRowLosesToAMarkerThatBreaksThePeriod) {
  for (const bool joint : {false, true}) {
    Scene s;
    std::vector<int> row;
    periodicRow(&s, &row);
    const int corner = s.addLandmark({3.6, -1.0});
    s.true_pose = Eigen::Vector3d(0.8, 0, 0);
    s.build();
    DJNN d = makeDjnn(joint ? kJoint : std::map<std::string, std::string>{});
    for (int k = 1; k < 4; ++k) s.observeLandmark(row[k]);
    s.observeLandmark(corner);
    const auto right = [&](const AssociationResult& r) {
      int n = 0;
      for (int i = 0; i < 4; ++i) {
        n += r.decision[i] == Decision::kPaired && r.landmark[i] == Scene::idOf(s.truth[i]);
      }
      return n;
    };
    const AssociationResult r = d.associate(s.context(0));
    if (joint) {
      EXPECT_EQ(right(r), 0);  // held: one scan's evidence
      EXPECT_EQ(d.stats().joint_held, 4u);
      EXPECT_EQ(right(d.associate(s.context(0.2))), 4);
      EXPECT_EQ(d.stats().joint_scans, 2u);
      EXPECT_EQ(d.stats().joint_held, 4u);
      DJNN per_scan = makeDjnn(
          {{"loop_closure_age", "30"}, {"landmark_density", "0.3"}, {"closure_margin", "0"}});
      EXPECT_EQ(right(per_scan.associate(s.context(0))), 4);
      EXPECT_EQ(per_scan.stats().joint_held, 0u);
    } else {
      EXPECT_LT(right(r), 4);  // the scene is one NN gets wrong
    }
  }
}

// Half a spacing off and nothing but the row in view: the true and the shifted assignment fit
// equally. Nothing may be paired, and nothing may start a tentative feature (a duplicate).
TEST(DJNNJoint, NearTieIsHeldUndecided) {
  for (const bool joint : {false, true}) {
    Scene s;
    std::vector<int> row;
    periodicRow(&s, &row);
    s.true_pose = Eigen::Vector3d(0.4, 0, 0);
    s.build();
    DJNN d = makeDjnn(joint ? kJoint : std::map<std::string, std::string>{});
    for (int k = 1; k < 4; ++k) s.observeLandmark(row[k]);
    const AssociationResult r = d.associate(s.context(0));
    int paired = 0;
    for (Decision x : r.decision) paired += x == Decision::kPaired;
    if (joint) {
      EXPECT_EQ(paired, 0);
      for (Decision x : r.decision) EXPECT_EQ(x, Decision::kRejected);
      EXPECT_EQ(d.stats().joint_held, 3u);
      EXPECT_TRUE(d.tentativeFeatures().empty());
    } else {
      EXPECT_EQ(paired, 3);
    }
  }
}

// Landmarks paired less than loop_closure_age ago: no loop closure, NN's pairing stands.
TEST(DJNNJoint, RecentlyPairedLandmarksAreLeftToNN) {
  Scene s;
  s.pose_cov = assoc_test::poseCov(0.05, 0.05, 0.005);
  s.R = assoc_test::diag2(0.03, deg2rad(1));
  for (int k = 0; k < 3; ++k) s.addLandmark({3.0, -1.0 + k});
  s.build();
  DJNN d = makeDjnn(kJoint);
  for (int k = 0; k < 3; ++k) s.observeLandmark(k);
  d.associate(s.context(0.0));  // never paired before: old, decided jointly
  EXPECT_EQ(d.stats().joint_scans, 1u);
  const AssociationResult r = d.associate(s.context(10.0));
  EXPECT_EQ(d.stats().joint_scans, 1u);
  for (Decision x : r.decision) EXPECT_EQ(x, Decision::kPaired);
  d.associate(s.context(41.0));  // 31 s after the last pairing: a loop closure again
  EXPECT_EQ(d.stats().joint_scans, 2u);
}

// A closure scan (an observation gates with a landmark never paired) with a landmark tracked a
// scan ago, the pose 0.5 m uncertain: "not in the map" for the tracked landmark's observation is
// within joint_margin of its pairing, and no hypothesis pairs it with anything else. It is paired
// as tracking pairs it, not held (a held sighting is one the filter does not use at that scan).
TEST(DJNNJoint, ATrackedLandmarkIsPairedInAClosureScan) {
  Scene s;
  s.R = assoc_test::diag2(0.03, deg2rad(1));
  const Eigen::Matrix2d tight = assoc_test::diag2(1e-4, 1e-4);
  const int tracked = s.addLandmark({3.0, -0.5}, tight);
  const int old = s.addLandmark({3.5, 1.5}, tight);
  s.pose_cov = assoc_test::poseCov(0.01, 0.01, 0.001);
  s.build();
  DJNN d = makeDjnn(kJoint);
  s.observeLandmark(tracked);
  const AssociationResult first = d.associate(s.context(0.0));
  ASSERT_EQ(first.decision[0], Decision::kPaired);
  ASSERT_EQ(first.landmark[0], Scene::idOf(tracked));

  s.pose_cov = assoc_test::poseCov(0.5, 0.5, 0.01);
  s.build();
  s.observations.clear();
  s.truth.clear();
  s.observeLandmark(tracked);
  s.observePoint(s.true_landmarks[old] + Eigen::Vector2d(1.0, 0.0));  // gates with `old`
  const AssociationResult r = d.associate(s.context(0.2));
  EXPECT_EQ(d.stats().joint_scans, 2u);  // the old landmark makes it a closure scan
  EXPECT_EQ(r.decision[0], Decision::kPaired);
  EXPECT_EQ(r.landmark[0], Scene::idOf(tracked));
  EXPECT_EQ(r.decision[1], Decision::kRejected);  // the closure itself stays held
  EXPECT_EQ(d.stats().joint_held, 1u);
}

// A closure along a row of markers laid by hand (a few centimetres off the period), the pose
// 0.3 m off along it with 1 m of uncertainty. Each scan from the true pose favours the truth by
// less than joint_margin: held. Then a clutter return one spacing past the row's end makes the
// row one marker along more likely by more than joint_margin. Decided on that scan alone the
// loop closes wrongly; on the evidence of all its held scans (closure_margin) the truth still
// leads and the scan is held. Once a marker off the row (the corridor's corner) is in view, the
// truth is decided.
TEST(DJNNJoint, AClosureIsDecidedOnTheEvidenceOfItsHeldScans) {
  for (const bool summed : {false, true}) {
    Scene s;
    s.pose_cov = assoc_test::poseCov(1.0, 0.05, 0.005);
    s.R = assoc_test::diag2(0.03, deg2rad(1));
    const double laid[] = {0.0, 0.015, -0.012, 0.016, -0.01, 0.0};
    std::vector<int> row;
    for (int k = 0; k < 6; ++k) {
      row.push_back(s.addLandmark({2.0 + 0.8 * k + laid[k], 0.5}, assoc_test::diag2(0.01, 0.01)));
    }
    const int corner = s.addLandmark({3.6, -1.0}, assoc_test::diag2(0.01, 0.01));
    s.true_pose = Eigen::Vector3d(0.3, 0, 0);
    s.build();
    std::map<std::string, std::string> params = kJoint;
    params["closure_margin"] = summed ? "10" : "0";
    DJNN d = makeDjnn(params);
    const auto scan = [&](bool noisy, double stamp, bool with_corner = false) {
      s.observations.clear();
      s.truth.clear();
      for (int k = 1; k < 4; ++k) s.observeLandmark(row[k]);
      if (with_corner) s.observeLandmark(corner);
      // A return one spacing past the row's end: out of the map if the pose is right, the
      // row's last marker if it is one spacing off.
      if (noisy) s.observePoint(s.true_landmarks[row[5]] + Eigen::Vector2d(0.8, 0.0));
      const AssociationResult r = d.associate(s.context(stamp));
      int truth = 0;
      int wrong = 0;
      for (int i = 0; i < 3; ++i) {
        if (r.decision[i] != Decision::kPaired) continue;
        (r.landmark[i] == Scene::idOf(row[i + 1]) ? truth : wrong) += 1;
      }
      return std::make_pair(truth, wrong);
    };
    double t = 0.0;
    for (int k = 0; k < 4; ++k) {
      const auto r = scan(false, t += 0.2);
      EXPECT_EQ(r.first + r.second, 0) << "a scan from the true pose was decided alone";
    }
    const auto bad = scan(true, t += 0.2);
    if (!summed) {
      EXPECT_EQ(bad.second, 3);  // the scene is one a per-scan margin gets wrong
      continue;
    }
    EXPECT_EQ(bad.first + bad.second, 0);
    const auto r = scan(false, t += 0.2, true);
    EXPECT_EQ(r.first, 3) << "the truth was not decided";
    EXPECT_EQ(r.second, 0);
  }
}

TEST(DJNNJoint, OnByDefaultAndValidated) {
  DJNN d;
  EXPECT_EQ(d.params().joint.loop_closure_age, 60.0);
  EXPECT_EQ(makeDjnn().params().joint.loop_closure_age, 0.0);  // the paper's DJNN
  EXPECT_THROW(makeDjnn({{"loop_closure_age", "-1"}}), ParameterError);
  EXPECT_THROW(makeDjnn({{"loop_closure_age", "30"}}), ParameterError);  // no density
  EXPECT_THROW(makeDjnn({{"joint_margin", "-1"}}), ParameterError);
  EXPECT_THROW(makeDjnn({{"closure_margin", "-1"}}), ParameterError);
  EXPECT_EQ(d.params().remembered.held_birth_cost, 0.0);
  EXPECT_THROW(makeDjnn({{"held_birth_cost", "-1"}}), ParameterError);
  EXPECT_EQ(d.params().spacing.landmark_spacing, 0.0);
  EXPECT_THROW(makeDjnn({{"landmark_spacing", "-1"}}), ParameterError);
  EXPECT_THROW(makeDjnn({{"landmark_spacing", "0.8"}}), ParameterError);  // no clutter density
  EXPECT_NO_THROW(makeDjnn({{"landmark_spacing", "0.8"}, {"clutter_density", "0.02"}}));
  EXPECT_NO_THROW(makeDjnn(kJoint));
}

}  // namespace test_djnn_joint
}  // namespace ekf_slam
