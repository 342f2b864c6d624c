// What the scans processed while lost saw is mapped at the fix (issue 34, item 3): the vehicle
// state carried back through the odometry, the lost scans associated and their new features
// initialised there, the fixed pose restored from a clone (EkfSlam::restorePose).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include <Eigen/Cholesky>

#include "ekf_slam/core/common/pose2d.h"
#include "ekf_slam/core/filter/ekf_slam.h"
#include "ekf_slam/core/filter/landmark_index.h"
#include "ekf_slam/core/pipeline/lost_scans.h"

namespace ekf_slam {
namespace test_lost_scans {

const RangeBearingModel kModel;
const Eigen::Matrix2d kR = Eigen::Vector2d(0.05 * 0.05, 0.01 * 0.01).asDiagonal();

Observation observe(const Eigen::Vector3d& pose, const Eigen::Vector2d& landmark) {
  Observation o;
  o.z = kModel.predict(pose, landmark);
  o.R = kR;
  return o;
}

// Straight ahead by `d` [m]: the step a motion model would give (F, Q in the map frame).
MotionStep forward(const Eigen::Vector3d& from, double d) {
  MotionStep s;
  s.pose = composePose(from, Eigen::Vector3d(d, 0.0, 0.0));
  s.F.setIdentity();
  s.F(0, 2) = -(s.pose.y() - from.y());
  s.F(1, 2) = s.pose.x() - from.x();
  s.Q = Eigen::Vector3d(0.02 * d * d, 0.02 * d * d, 1e-4).asDiagonal();
  return s;
}

TEST(RestorePose, CloneThenPredictThenRestoreIsTheStateBefore) {
  EkfSlam ekf;
  ekf.reset(Eigen::Vector3d(1, 2, 0.3), Eigen::Vector3d(0.1, 0.2, 0.01).asDiagonal());
  ekf.addLandmark({5, 0.2}, kR, kModel);
  ekf.addLandmark({7, -0.4}, kR, kModel);
  const Eigen::VectorXd mean = ekf.mean();
  const Eigen::MatrixXd P = ekf.covariance();
  const CloneId c = ekf.addClone();
  ASSERT_TRUE(ekf.predict(forward(ekf.pose(), 3.0)));
  ASSERT_TRUE(ekf.predict(forward(ekf.pose(), 2.0)));
  ASSERT_TRUE(ekf.restorePose(c));
  EXPECT_EQ(ekf.numClones(), 0u);
  EXPECT_TRUE(ekf.mean().isApprox(mean, 1e-12));
  EXPECT_TRUE(Eigen::MatrixXd(ekf.covariance()).isApprox(P, 1e-12));
  EXPECT_FALSE(ekf.restorePose(c));
}

// A vehicle drives past a tree no map holds while lost; at the fix it sees two mapped ones.
struct LostDrive {
  Eigen::Vector2d mapped_a{20.0, 3.0}, mapped_b{22.0, -4.0};
  Eigen::Vector2d unmapped{6.0, 4.0};
  Eigen::Vector3d start{0.0, 0.0, 0.0};
  // The estimate's frame is off by this (a kidnap): dead reckoning = offset o truth.
  Eigen::Vector3d offset{15.0, -10.0, 1.0};
  LostScans lost;
  Eigen::Vector3d truth_now, dead_reckoned_now;

  // `sightings`: the unmapped tree is seen in the first that many scans; `always_a`: every scan
  // also sees mapped tree a (so that the scans without the unmapped tree are kept too).
  explicit LostDrive(int sightings, bool always_a = false) {
    Eigen::Vector3d truth = start;
    for (int k = 0; k < 5; ++k) {
      const MotionStep step = forward(truth, 1.0);
      // The odometry in the dead-reckoned frame: the same motion, turned by the offset.
      MotionStep dr = forward(composePose(offset, truth), 1.0);
      lost.carry(dr);
      truth = step.pose;
      std::vector<Observation> seen;
      if (k < sightings) seen.push_back(observe(truth, unmapped));
      if (always_a) seen.push_back(observe(truth, mapped_a));
      lost.add(static_cast<std::uint32_t>(k), composePose(offset, truth), seen);
    }
    // One more step to the fix's scan.
    lost.carry(forward(composePose(offset, truth), 1.0));
    truth_now = forward(truth, 1.0).pose;
    dead_reckoned_now = composePose(offset, truth_now);
  }

  // The filter after the fix: the true pose (as a relocaliser gives it), two mapped trees.
  EkfSlam fixedFilter() const {
    EkfSlam ekf;
    ekf.reset(truth_now, Eigen::Vector3d(0.01, 0.01, 1e-4).asDiagonal());
    ekf.insertLandmark(mapped_a, 0.01 * Eigen::Matrix2d::Identity(), 100);
    ekf.insertLandmark(mapped_b, 0.01 * Eigen::Matrix2d::Identity(), 101);
    return ekf;
  }
};

TEST(MapLostScans, TheTreeSeenWhileLostIsMappedWhereItIsCorrelatedWithThePose) {
  const LostDrive drive(4);
  EkfSlam ekf = drive.fixedFilter();
  const Eigen::Vector3d pose_before = ekf.pose();
  const LostScanMapping m = mapLostScans(ekf, kModel, drive.lost, drive.dead_reckoned_now, {});
  EXPECT_EQ(m.scans, 4);  // scans without observations are not kept
  ASSERT_EQ(m.created.size(), 1u);
  EXPECT_EQ(m.sightings[0], 4u);
  EXPECT_EQ(m.dropped, 0);
  EXPECT_EQ(ekf.numClones(), 0u);
  EXPECT_TRUE(ekf.mean().allFinite());
  // The fixed pose is the pose again (what the lost scans add is only through correlations).
  EXPECT_LT((ekf.pose() - pose_before).norm(), 1e-3);
  const int k = ekf.indexOf(m.created[0]);
  ASSERT_GE(k, 0);
  // Where the tree is, within its covariance, which holds the odometry chain's uncertainty
  // (several sightings of a 5 cm sensor would otherwise give millimetres).
  const Eigen::Vector2d e = ekf.landmark(k) - drive.unmapped;
  const Eigen::Matrix2d C = ekf.landmarkCovariance(k);
  EXPECT_LT(e.dot(C.ldlt().solve(e)), 13.8) << e.transpose();
  EXPECT_GT(C.trace(), 0.02);
  // Correlated with the pose: not a fresh, independent prior.
  const Eigen::Matrix<double, 3, 2> Pvm = ekf.covariance().block<3, 2>(0, ekf.stateRow(k));
  EXPECT_GT(Pvm.norm(), 1e-4);
}

TEST(MapLostScans, AFeatureSeenTooFewTimesIsDropped) {
  const LostDrive drive(2);
  EkfSlam ekf = drive.fixedFilter();
  const Eigen::MatrixXd P = ekf.covariance();
  const LostScanMapping m = mapLostScans(ekf, kModel, drive.lost, drive.dead_reckoned_now, {});
  EXPECT_TRUE(m.created.empty());
  EXPECT_EQ(m.dropped, 1);
  EXPECT_EQ(ekf.numLandmarks(), 2u);
  // Seen only at its initialisation and once more: the second sighting is information the pose
  // and map keep; nothing is made worse.
  EXPECT_LE(ekf.covariance().trace(), P.trace() + 1e-9);
}

// What the associator weighs at the fix (DataAssociation::landmarkFromLostScans): every kept lost
// scan, oldest first, whether it saw the new landmark, and where the landmark lay in its sensor
// frame.
TEST(MapLostScans, TheLooksListEveryLostScanOldestFirst) {
  const LostDrive drive(3, true);
  EkfSlam ekf = drive.fixedFilter();
  const LostScanMapping m = mapLostScans(ekf, kModel, drive.lost, drive.dead_reckoned_now, {});
  ASSERT_EQ(m.created.size(), 1u);
  ASSERT_EQ(m.looks.size(), 1u);
  ASSERT_EQ(m.looks[0].size(), 5u);
  Eigen::Vector3d truth = drive.start;
  for (int k = 0; k < 5; ++k) {
    truth = forward(truth, 1.0).pose;
    EXPECT_EQ(m.looks[0][k].seen, k < 3) << k;
    const Eigen::Vector3d s = kModel.sensorPose(truth);
    const Eigen::Vector2d expected = rotation2d(-s.z()) * (drive.unmapped - s.head<2>());
    EXPECT_LT((m.looks[0][k].in_sensor - expected).norm(), 0.3) << k;
  }
}

// The lost path (ScanReport::lost_path) takes each lost scan's pose from the mapping: carried back
// from the fix and updated with that scan's pairings, newest first, one per scan carried back to.
TEST(MapLostScans, ThePosesAreTheLostScansNewestFirstNearTheTruth) {
  const LostDrive drive(3, true);
  EkfSlam ekf = drive.fixedFilter();
  const LostScanMapping m = mapLostScans(ekf, kModel, drive.lost, drive.dead_reckoned_now, {});
  ASSERT_EQ(m.poses.size(), 5u);
  Eigen::Vector3d truth = drive.start;
  for (int k = 0; k < 5; ++k) {
    truth = forward(truth, 1.0).pose;
    const auto& [scan, pose] = m.poses[4 - k];
    EXPECT_EQ(scan, static_cast<std::uint32_t>(k));
    EXPECT_LT((pose.head<2>() - truth.head<2>()).norm(), 0.2) << k;
    EXPECT_LT(std::abs(wrapAngle(pose.z() - truth.z())), 0.02) << k;
  }
}

TEST(MapLostScans, ACallersIndexOfAnyCellSizeMapsTheSameAndEndsInStep) {
  // The candidates come from a landmark index: the pipeline's (20 m cells here, so the query
  // visits cells, not every occupied one) or, without one, a local one. Far trees, beyond every
  // observation's reach, must change nothing either way.
  const LostDrive drive(4);
  EkfSlam a = drive.fixedFilter();
  for (int i = 0; i < 8; ++i) {
    for (int j = 0; j < 8; ++j)
      a.insertLandmark({200.0 + 25.0 * i, 200.0 + 25.0 * j}, 0.01 * Eigen::Matrix2d::Identity(),
                       200 + 8 * i + j);
  }
  EkfSlam b = a;
  LandmarkIndex index(20.0);
  index.sync(b);
  const LostScanMapping ma = mapLostScans(a, kModel, drive.lost, drive.dead_reckoned_now, {});
  const LostScanMapping mb =
      mapLostScans(b, kModel, drive.lost, drive.dead_reckoned_now, {}, &index);
  ASSERT_EQ(ma.created.size(), 1u);
  EXPECT_EQ(ma.created, mb.created);
  EXPECT_EQ(ma.sightings, mb.sightings);
  EXPECT_EQ(ma.dropped, mb.dropped);
  EXPECT_EQ(a.landmarkIds(), b.landmarkIds());
  EXPECT_TRUE(a.mean() == b.mean());  // bit for bit
  EXPECT_TRUE(Eigen::MatrixXd(a.covariance()) == Eigen::MatrixXd(b.covariance()));
  // The given index holds the new tree where the filter has it.
  std::vector<int> near;
  index.query(b, drive.unmapped, 5.0, &near);
  const int k = b.indexOf(mb.created[0]);
  EXPECT_NE(std::find(near.begin(), near.end(), k), near.end());
}

TEST(LostScans, DroppingTheNewestKeepsTheOdometryToNow) {
  LostScans lost;
  lost.carry(forward(Eigen::Vector3d::Zero(), 1.0));  // nothing kept yet: ignored
  Observation o;
  o.z = Eigen::Vector2d(5.0, 0.1);
  lost.add(0, Eigen::Vector3d::Zero(), {o});
  lost.carry(forward(Eigen::Vector3d::Zero(), 1.0));
  lost.add(1, Eigen::Vector3d(1, 0, 0), {o});
  lost.add(2, Eigen::Vector3d(1, 0, 0), {});  // no observations: not kept
  lost.carry(forward(Eigen::Vector3d(1, 0, 0), 2.0));
  ASSERT_EQ(lost.scans().size(), 2u);
  lost.dropFrom(1);
  ASSERT_EQ(lost.scans().size(), 1u);
  // Both steps composed: variance 0.02 (1 m) + 0.08 (2 m) along x.
  EXPECT_NEAR(lost.scans()[0].Q(0, 0), 0.1, 1e-12);
}

}  // namespace test_lost_scans
}  // namespace ekf_slam
