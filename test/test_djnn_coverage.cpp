// DJNN's coverage_cell (docs/djnn.md, "Where the sensor has looked"): in the joint decision the
// cost of "not in the map" for an observation depends on how often the sensor has looked at its
// source: where it looked, an unmapped landmark is unlikely and only clutter remains.
#include <cmath>
#include <map>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "association_fixtures.h"
#include "djnn_fixtures.h"
#include "ekf_slam/core/common/angles.h"
#include "ekf_slam/core/association/djnn/djnn.h"

namespace ekf_slam {
namespace {

using assoc_test::makeDjnn;
using assoc_test::Scene;

std::map<std::string, std::string> params(bool coverage) {
  std::map<std::string, std::string> p = {
      {"loop_closure_age", "30"},          {"landmark_density", "0.3"},
      {"clutter_density", "0.02"},         {"detection_probability", "0.7"},
      {"individual_probability", "0.999"}, {"ambiguity_probability", "0.999"}};
  if (coverage) p["coverage_cell"] = "0.25";
  return p;
}

// Ten scans from `pose` (heading included) that see one far point gating nothing: DJNN counts the
// sensor region of each, and no joint decision runs.
void look(DJNN* d, const std::vector<Eigen::Vector2d>& landmarks, const Eigen::Vector3d& pose) {
  for (int k = 0; k < 10; ++k) {
    Scene s;
    s.est_pose = s.true_pose = pose;
    s.pose_cov = assoc_test::poseCov(0.03, 0.03, 0.003);
    for (const Eigen::Vector2d& p : landmarks) s.addLandmark(p);
    s.build();
    s.observePoint(pose.head<2>() + Eigen::Vector2d(std::cos(pose(2)), std::sin(pose(2))) * 25.0);
    d->associate(s.context(0.1 * k));
  }
  EXPECT_EQ(d->stats().joint_scans, 0u);
}

// A landmark revisited with the pose known to centimetres, observed a little off (D^2 about 7):
// against "an unmapped landmark just there" (0.3 per m^2) the pairing is within the margin and is
// held. Where the sensor has looked ten times at P_D 0.7 that place holds no unmapped landmark,
// "not in the map" is clutter alone: paired. Where it never looked (the scans faced away): held.
TEST(DJNNCoverage, NullCostWhereTheSensorLookedAndWhereItNeverLooked) {
  const std::vector<Eigen::Vector2d> map = {{3.0, 0.5}};
  for (int where = 0; where < 3; ++where) {  // 0: no coverage; 1: looked at it; 2: looked away
    DJNN d = makeDjnn(params(where > 0));
    if (where == 1) look(&d, map, Eigen::Vector3d(0, 0, 0));
    if (where == 2) look(&d, map, Eigen::Vector3d(0, 0, M_PI));
    Scene s;
    s.pose_cov = assoc_test::poseCov(0.03, 0.03, 0.003);
    s.R = assoc_test::diag2(0.03, deg2rad(1));
    const int j = s.addLandmark(map[0]);
    s.build();
    s.observeLandmark(j);
    const double z0 = s.observations[0].z(0);
    s.observations[0].z(0) = z0 + 0.1;
    const double m1 = s.context(0).individual(0, j).mahalanobis;
    s.observations[0].z(0) = z0 + 0.1 * std::sqrt(7.0 / m1);
    ASSERT_NEAR(s.context(0).individual(0, j).mahalanobis, 7.0, 1e-6);
    const AssociationResult r = d.associate(s.context(100.0));
    EXPECT_EQ(d.stats().joint_scans, 1u) << where;
    const bool paired = r.decision[0] == Decision::kPaired && r.landmark[0] == Scene::idOf(j);
    EXPECT_EQ(paired, where == 1) << where;
    EXPECT_EQ(d.stats().joint_held, where == 1 ? 0u : 1u) << where;
  }
}

// The end of a row, back with the pose a spacing uncertain along it: the row of six mapped
// markers 0.8 m apart (x = 4.0 .. 8.0) and two markers before it never mapped (2.4, 3.2) are all
// seen. The truth leaves the two never-mapped markers out of the map; the scan shifted two
// spacings pairs them with the row's first markers and leaves the row's last two out instead.
// (The scan shifted by one spacing trades one of them for the row's last.) With one density for
// "not in the map" these tie within the margin (the prior favours the truth a little) and the
// scan is held; with the row's part looked at (x > 3.8) and the part before it not, leaving the
// row's end out costs clutter and the truth is decided. (Seed 20's closure is not this scene: its
// shift leaves no observation out, docs/djnn.md.)
TEST(DJNNCoverage, AShiftThatLeavesLookedAtMarkersOutLoses) {
  std::vector<Eigen::Vector2d> map;
  for (int k = 0; k < 6; ++k) map.emplace_back(4.0 + 0.8 * k, 0.5);
  for (const bool coverage : {false, true}) {
    DJNN d = makeDjnn(params(coverage));
    if (coverage) look(&d, map, Eigen::Vector3d(3.8, 0, 0));
    Scene s;
    s.pose_cov = assoc_test::poseCov(0.6, 0.05, 0.003);
    s.R = assoc_test::diag2(0.03, deg2rad(1));
    std::vector<int> row;
    for (const Eigen::Vector2d& p : map)
      row.push_back(s.addLandmark(p, assoc_test::diag2(0.0025, 0.0025)));
    s.est_pose = Eigen::Vector3d(0.05, 0, 0);  // the truth is at the origin
    s.build();
    s.observePoint({2.4, 0.5});
    s.observePoint({3.2, 0.5});
    for (int j : row) s.observeLandmark(j);
    const AssociationResult r = d.associate(s.context(100.0));
    EXPECT_EQ(d.stats().joint_scans, 1u);
    int right = 0, wrong = 0;
    for (std::size_t i = 2; i < s.observations.size(); ++i) {
      if (r.decision[i] != Decision::kPaired) continue;
      (r.landmark[i] == Scene::idOf(s.truth[i]) ? right : wrong)++;
    }
    for (int i = 0; i < 2; ++i) wrong += r.decision[i] == Decision::kPaired;
    EXPECT_EQ(wrong, 0) << coverage;
    EXPECT_EQ(right, coverage ? 6 : 0) << coverage;
    EXPECT_EQ(d.stats().joint_held, coverage ? 0u : 7u) << coverage;  // without: all but 2.4
  }
}

TEST(DJNNCoverage, Validation) {
  EXPECT_EQ(DJNN().params().coverage_cell, 0.0);
  EXPECT_THROW(makeDjnn({{"coverage_cell", "-1"}}), ParameterError);
  EXPECT_THROW(makeDjnn({{"coverage_cell", "0.2"}}), ParameterError);  // no joint decision
  std::map<std::string, std::string> p = params(true);
  p.erase("clutter_density");
  EXPECT_THROW(makeDjnn(p), ParameterError);  // "not in the map" needs clutter where looked
  EXPECT_NO_THROW(makeDjnn(params(true)));
  p = params(true);
  p["coverage_max_looks"] = "-1";
  EXPECT_THROW(makeDjnn(p), ParameterError);
}

}  // namespace
}  // namespace ekf_slam

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
