// DJNN's held window (docs/djnn.md, "Deciding a held closure on the held scans"): a pairing of a
// held scan is weighed from the pose it was seen from (the odometry's noise since taken out of the
// current pose's covariance); on a row of markers with the pose one spacing off, scans that each
// leave the closure undecided decide it together, and one scan whose noise favours the shifted
// row past the margin no longer decides it when the held scans disagree.
#include <cmath>
#include <map>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include <Eigen/LU>

#include "association_fixtures.h"
#include "djnn_fixtures.h"
#include "ekf_slam/core/common/angles.h"
#include "ekf_slam/core/association/djnn/djnn.h"
#include "ekf_slam/core/association/djnn/held_window.h"
#include "ekf_slam/core/association/joint_ml.h"
#include "ekf_slam/core/filter/motion_models.h"

namespace ekf_slam {
namespace {

using assoc_test::makeDjnn;
using assoc_test::Scene;

MotionStep step(const Eigen::Vector3d& from, const Eigen::Vector3d& to, const Eigen::Matrix3d& Q) {
  MotionStep s;
  s.pose = to;
  s.F = Eigen::Matrix3d::Identity();
  s.F(0, 2) = -(to.y() - from.y());
  s.F(1, 2) = to.x() - from.x();
  s.Q = Q;
  return s;
}

// Seen from a held scan's pose and carried to the current filter by the odometry, a pairing has
// the likelihood it had at its own scan; two pairings at one pose with no odometry in between
// have the joint likelihood of one scan.
TEST(WindowLikelihood, HeldPairingIsWeighedFromItsOwnPose) {
  Scene s;
  s.pose_cov = assoc_test::poseCov(0.5, 0.3, 0.05);
  s.R = assoc_test::diag2(0.05, deg2rad(1));
  const int a = s.addLandmark({4.0, 1.0}, assoc_test::diag2(0.1, 0.2));
  const int b = s.addLandmark({6.0, -2.0}, assoc_test::diag2(0.15, 0.1));
  s.true_pose = Eigen::Vector3d(0.3, -0.2, 0.04);
  s.build();
  s.observeLandmark(a);
  s.observeLandmark(b);
  const AssociationContext then = s.context(0);
  const AssociationContext::Individual ia = then.individual(0, a);
  const double joint = jointInnovationCost(then, {{0, a}, {1, b}}) + 4.0 * std::log(2.0 * M_PI);

  HeldWindow window(3);
  window.advance(s.ekf.pose(), s.ekf.poseCovariance());
  window.push(1, s.ekf.pose(), {{s.observations[0], {}}, {s.observations[1], {}}});
  // Odometry: 1.5 m ahead, a turn, and its noise.
  const Eigen::Vector3d to(1.6, 0.7, 0.3);
  const Eigen::Matrix3d Q = assoc_test::poseCov(0.2, 0.1, 0.03);
  ASSERT_TRUE(s.ekf.predict(step(s.ekf.pose(), to, Q)));
  ASSERT_TRUE(window.advance(s.ekf.pose(), s.ekf.poseCovariance()));
  const std::vector<CarriedScan>& scans = window.scans(s.ekf.pose());
  ASSERT_EQ(scans.size(), 1u);
  EXPECT_TRUE(scans[0].Q.isApprox(Q, 1e-9));
  WindowLikelihood w(s.ekf, s.model, scans);
  double mah = 0.0;
  const WindowPairing pa{0, a, s.observations[0].z, s.R, MeasurementKind::kRangeBearing, 0.0};
  const double cost = w.conditionalCost(pa, &mah);
  EXPECT_NEAR(mah, ia.mahalanobis, 1e-6);
  EXPECT_NEAR(cost, ia.mahalanobis + ia.log_det_S + 2.0 * std::log(2.0 * M_PI), 1e-6);
  // The chain rule over the held scan's two pairings gives the scan's joint likelihood.
  double chain = w.add(pa);
  chain += w.add({0, b, s.observations[1].z, s.R, MeasurementKind::kRangeBearing, 0.0});
  EXPECT_NEAR(chain, joint, 1e-6);
}

// A correction between two scans (the covariance shrinks) is not odometry: the window empties.
TEST(HeldWindow, ClearedByACorrection) {
  HeldWindow window(3);
  const Eigen::Matrix3d P = assoc_test::poseCov(1.0, 1.0, 0.1);
  window.advance(Eigen::Vector3d::Zero(), P);
  window.push(1, Eigen::Vector3d::Zero(), {{Observation(), {}}});
  const MotionStep m = step(Eigen::Vector3d::Zero(), Eigen::Vector3d(0.1, 0, 0),
                            assoc_test::poseCov(0.1, 0.1, 0.01));
  EXPECT_TRUE(window.advance(m.pose, m.F * P * m.F.transpose() + m.Q));
  EXPECT_FALSE(window.empty());
  EXPECT_FALSE(window.advance(Eigen::Vector3d(0.2, 0, 0), 0.5 * P));
  EXPECT_TRUE(window.empty());
}

// A row of markers 0.8 m apart (the fourth 4 cm out of step) and the pose one spacing off (1 m
// std dev along the row): a scan of four markers favours the true pairing over the one shifted by
// a marker by about 2.4 (-2 ln), less than the margin, with noise of about 2.5.
struct Row {
  Scene s;
  std::vector<int> row;
  Row() {
    s.pose_cov = assoc_test::poseCov(1.0, 0.05, 0.005);
    s.R = assoc_test::diag2(0.03, deg2rad(1));
    for (int k = 0; k < 7; ++k) {
      const double x = 2.0 + 0.8 * k + (k == 3 ? 0.04 : 0.0);
      row.push_back(s.addLandmark({x, 0.5}, assoc_test::diag2(0.01, 0.01)));
    }
    s.true_pose = Eigen::Vector3d(0.8, 0, 0);
    s.build();
  }
  void observe(std::mt19937* rng) {
    s.observations.clear();
    s.truth.clear();
    for (int k = 1; k < 5; ++k) s.observeLandmark(row[k], rng);
  }
  // A scan that fits the shifted row from the estimate, the fourth marker 5 cm farther: noise
  // that favours the shift by about 8, past the margin.
  void observeShifted() {
    s.observations.clear();
    s.truth.clear();
    for (int i = 0; i < 4; ++i) {
      Eigen::Vector2d p = s.landmarks[row[i]];
      if (i == 3) p.x() += 0.05;
      Observation o;
      o.z = s.model.predict(s.est_pose, p);
      o.R = s.R;
      s.observations.push_back(o);
      s.truth.push_back(row[i + 1]);
    }
  }
  // The robot stands; the filter predicts with a little odometry noise.
  void wait() {
    s.ekf.predict(step(s.ekf.pose(), s.ekf.pose(), assoc_test::poseCov(0.01, 0.01, 0.001)));
  }
};

struct Outcome {
  int right = 0;
  int wrong = 0;
  int scans = 0;  ///< scans until the first pairing (or all)
};

// Runs `noisy` noisy scans then `shifted` shifted ones; stops at the first scan that pairs.
Outcome run(int window, int noisy, int shifted, double margin = 0.0, int confirmations = 0) {
  Row r;
  DJNN d = makeDjnn({{"loop_closure_age", "30"},
                     {"landmark_density", "0.3"},
                     {"held_window_scans", std::to_string(window)},
                     {"held_window_margin", std::to_string(margin)},
                     {"held_confirmations", std::to_string(confirmations)}});
  std::mt19937 rng(3);
  Outcome out;
  for (int scan = 0; scan < noisy + shifted; ++scan) {
    if (scan > 0) r.wait();
    if (scan < noisy) {
      r.observe(&rng);
    } else {
      r.observeShifted();
    }
    const AssociationResult res = d.associate(r.s.context(0.2 * scan));
    ++out.scans;
    for (std::size_t i = 0; i < res.decision.size(); ++i) {
      if (res.decision[i] != Decision::kPaired) continue;
      ++(res.landmark[i] == r.s.expectId(static_cast<int>(i)) ? out.right : out.wrong);
    }
    if (out.right + out.wrong > 0) break;
  }
  return out;
}

// Each scan alone is held (the truth within the margin of the shift); with the window the held
// scans decide the truth.
TEST(DJNNHeldWindow, HeldScansDecideTogether) {
  const Outcome alone = run(0, 10, false);
  EXPECT_EQ(alone.right + alone.wrong, 0);  // every single scan within the margin: held
  const Outcome window = run(30, 10, false);
  EXPECT_EQ(window.wrong, 0);
  EXPECT_EQ(window.right, 4);
  EXPECT_LT(window.scans, 10);
  // A window margin no ten scans reach: held throughout.
  const Outcome strict = run(30, 10, false, 200.0);
  EXPECT_EQ(strict.right + strict.wrong, 0);
}

// One scan whose noise passes the margin for the shifted row decides it alone; after a held scan
// that favours the truth, the window weighs both and does not pair the shift.
TEST(DJNNHeldWindow, OneScansNoiseNoLongerDecidesAShift) {
  const Outcome alone = run(0, 1, true);
  EXPECT_EQ(alone.scans, 2);
  EXPECT_EQ(alone.right, 0);
  EXPECT_EQ(alone.wrong, 4);  // the scene is one that decides wrongly scan by scan
  const Outcome window = run(30, 1, true);
  EXPECT_EQ(window.wrong, 0);
}

// held_confirmations (djnn_confirm.cpp): the shifted scan follows a held scan whose joint best
// was the truth, so its lead (a pose correction one marker spacing away) did not repeat: held.
// The same shifted scan again repeats its own lead and is decided.
TEST(DJNNHeldConfirmations, OnlyALeadThatRepeatsIsDecided) {
  const Outcome confirmed = run(0, 1, 1, 0.0, 1);
  EXPECT_EQ(confirmed.right + confirmed.wrong, 0);  // off, this scan decides the shift (above)
  const Outcome repeated = run(0, 1, 2, 0.0, 1);
  EXPECT_EQ(repeated.scans, 3);
  EXPECT_EQ(repeated.wrong, 4);
  // Two confirmations: the second shifted scan still follows a held scan led by the truth.
  const Outcome twice = run(0, 1, 2, 0.0, 2);
  EXPECT_EQ(twice.right + twice.wrong, 0);
  EXPECT_EQ(run(0, 1, 3, 0.0, 2).wrong, 4);
  EXPECT_EQ(DJNN().params().held_confirmations, 0);
  EXPECT_THROW(makeDjnn({{"held_confirmations", "-1"}}), ParameterError);
}

TEST(DJNNHeldWindow, OffByDefaultAndValidated) {
  EXPECT_EQ(DJNN().params().held_window_scans, 0);
  EXPECT_THROW(makeDjnn({{"held_window_scans", "-1"}}), ParameterError);
  EXPECT_EQ(DJNN().params().held_window_margin, 0.0);
  EXPECT_THROW(makeDjnn({{"held_window_margin", "-1"}}), ParameterError);
  EXPECT_NO_THROW(makeDjnn({{"held_window_scans", "20"}}));
}

}  // namespace
}  // namespace ekf_slam

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
