// DJNN's tentative features and the pose estimate (docs/djnn.md, "Tentative features and the pose
// error"): with tentative_follow_pose they follow the pose's correction in each update, and a
// sighting is matched to a tentative feature without the absolute pose covariance in the gate (the
// pose error is common to both); static_heading lets the static test allow for a heading error
// common to sightings taken from different distances; the density and shift tests weigh the scan's
// pairings jointly (docs/djnn.md). All off = the behaviour before them.
#include <map>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "association_fixtures.h"
#include "djnn_fixtures.h"
#include "ekf_slam/core/association/djnn/djnn.h"
#include "ekf_slam/core/common/angles.h"

namespace ekf_slam {
namespace test_djnn_tentative_pose {

using assoc_test::makeDjnn;
using assoc_test::Scene;

TEST(DJNNTentativePose, TentativeFeatureFollowsThePoseCorrection) {
  for (const bool follow : {false, true}) {
    Scene s;
    s.build();
    DJNN d = makeDjnn({{"tentative_follow_pose", follow ? "true" : "false"}});
    s.observePoint({5, 0});
    ASSERT_EQ(d.associate(s.context(0)).decision[0], Decision::kTentative);
    // The update moved the pose 0.3 m along x and turned it by 0.1 rad.
    d.poseCorrected(Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(0.3, 0, 0.1));
    const std::vector<TentativeFeature> t = d.tentativeFeatures();
    ASSERT_EQ(t.size(), 1u);
    const Eigen::Vector2d expected =
        follow ? Eigen::Vector2d(0.3 + 5 * std::cos(0.1), 5 * std::sin(0.1))
               : Eigen::Vector2d(5, 0);
    EXPECT_NEAR((t[0].position - expected).norm(), 0.0, 1e-9) << "follow " << follow;
  }
}

// The pose is uncertain by 1 m, the sightings by a few cm. Point A is seen, then only point B,
// 0.8 m from it (A missed, as a sensor with P_D 0.5 does: the miss does not drop A). With the
// absolute pose covariance in the gate B's sighting is taken for A: the static test fails and A's
// history is lost (a restart). With the feature following the pose, B is a feature of its own and A
// keeps its sighting.
TEST(DJNNTentativePose, NeighbourIsNotTakenForAMissedFeature) {
  for (const bool follow : {false, true}) {
    Scene s;
    s.pose_cov = assoc_test::poseCov(1.0, 1.0, deg2rad(0.5));
    s.R = assoc_test::diag2(0.03, deg2rad(1));
    s.build();
    DJNN d = makeDjnn({{"tentative_follow_pose", follow ? "true" : "false"},
                       {"static_test", "true"},
                       {"detection_probability", "0.5"},
                       {"admit_evidence", "5"}});
    s.observePoint({3, 0.4});
    d.associate(s.context(0));
    s.observations.clear();
    s.truth.clear();
    s.observePoint({3.8, -0.4});
    d.associate(s.context(0.2));
    EXPECT_EQ(d.stats().static_restarts, follow ? 0u : 1u) << "follow " << follow;
    EXPECT_EQ(d.tentativeFeatures().size(), follow ? 2u : 1u) << "follow " << follow;
  }
}

// A static point seen from 4.5 m and then from 0.8 m while the pose estimate's heading is off by
// 1 deg (within its 1 deg standard deviation): the two sightings differ by 3.7 m x 0.0175 rad =
// 6.5 cm across, several times their noise. Without static_heading the static test restarts the
// feature; with it the heading error is allowed for.
TEST(DJNNTentativePose, StaticTestAllowsForACommonHeadingError) {
  for (const bool heading : {false, true}) {
    Scene s;
    s.pose_cov = assoc_test::poseCov(0.05, 0.05, deg2rad(1));
    s.R = assoc_test::diag2(0.01, deg2rad(0.2));
    s.est_pose = Eigen::Vector3d(0, 0, deg2rad(1));  // the truth is heading 0
    s.build();
    DJNN d = makeDjnn({{"static_heading", heading ? "true" : "false"},
                       {"tentative_follow_pose", "true"},
                       {"static_test", "true"},
                       {"admit_evidence", "5"}});
    s.observePoint({4.5, 0});
    d.associate(s.context(0));
    // The vehicle drove 3.7 m towards the point (estimate and truth alike).
    s.true_pose = Eigen::Vector3d(3.7, 0, 0);
    s.est_pose = Eigen::Vector3d(3.7, 0, deg2rad(1));
    s.build();
    s.observations.clear();
    s.truth.clear();
    s.observePoint({4.5, 0});
    d.associate(s.context(3.7));
    EXPECT_EQ(d.stats().static_restarts, heading ? 0u : 1u) << "static_heading " << heading;
  }
}

// The pose is uncertain by 1 m; landmark A (well known) is seen where it should be, which fixes the
// pose, and a marker never mapped, 1.2 m from landmark B, lies inside B's gate. NN pairs it with B;
// given A's pairing it is far less likely than an unmapped landmark at density 0.3 per m^2.
TEST(DJNNTentativePose, DensityTestWithdrawsAPairingTheOthersContradict) {
  for (const bool density : {false, true}) {
    Scene s;
    s.pose_cov = assoc_test::poseCov(1.0, 1.0, 0.01);
    s.R = assoc_test::diag2(0.03, deg2rad(1));
    const int a = s.addLandmark({3, 1}, assoc_test::diag2(0.02, 0.02));
    s.addLandmark({4, -1}, assoc_test::diag2(0.02, 0.02));
    s.build();
    DJNN d = makeDjnn({{"landmark_density", density ? "0.3" : "0"}});
    s.observeLandmark(a);
    s.observePoint({4, -2.2});
    const AssociationResult r = d.associate(s.context(0));
    EXPECT_EQ(r.decision[0], Decision::kPaired);
    EXPECT_EQ(r.decision[1], density ? Decision::kRejected : Decision::kPaired) << density;
  }
}

// A row of landmarks 0.8 m apart seen from a pose that is 0.4 m off along the row, with a pose
// uncertainty of 1 m: the scan fits the row shifted by one spacing as well as the pairing NN
// chose. With the shift test the pairings that differ are left undecided (rejected).
TEST(DJNNTentativePose, ShiftTestLeavesAnAmbiguousShiftUndecided) {
  for (const bool shift : {false, true}) {
    Scene s;
    s.pose_cov = assoc_test::poseCov(1.0, 0.05, 0.005);
    s.R = assoc_test::diag2(0.03, deg2rad(1));
    std::vector<int> row;
    for (int k = 0; k < 5; ++k) row.push_back(s.addLandmark({2.0 + 0.8 * k, 0.5}));
    s.true_pose = Eigen::Vector3d(0.4, 0, 0);
    s.build();
    DJNN d = makeDjnn({{"shift_test", shift ? "true" : "false"}});
    for (int k = 1; k < 4; ++k) s.observeLandmark(row[k]);
    const AssociationResult r = d.associate(s.context(0));
    int paired = 0;
    for (Decision x : r.decision) paired += x == Decision::kPaired;
    if (shift) {
      EXPECT_LT(paired, 3);
      EXPECT_EQ(d.stats().shifts_ambiguous, 1u);
    } else {
      EXPECT_EQ(paired, 3);
    }
  }
}

TEST(DJNNTentativePose, DefaultsOffAndFlagsValidated) {
  DJNN d;
  EXPECT_FALSE(d.params().follow_pose.tentative_follow_pose);
  EXPECT_FALSE(d.params().static_test.static_heading);
  EXPECT_FALSE(d.params().shift.shift_test);
  EXPECT_EQ(d.params().density.landmark_density, 0.0);
  EXPECT_THROW(makeDjnn({{"landmark_density", "-1"}}), ParameterError);
  EXPECT_THROW(makeDjnn({{"shift_margin", "-1"}}), ParameterError);
  EXPECT_THROW(makeDjnn({{"tentative_follow_pose", "maybe"}}), ParameterError);
  EXPECT_THROW(makeDjnn({{"static_heading", "2"}}), ParameterError);
}

}  // namespace test_djnn_tentative_pose
}  // namespace ekf_slam
