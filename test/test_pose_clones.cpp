// Pose clones in the EKF state (EkfSlam::addClone / removeClone / Pairing::clone): a clone is an
// exact copy of the pose, it follows the map through predict and update, an observation applied
// against it is the observation applied at the time, and removing it is its marginalisation.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include <Eigen/Core>
#include <Eigen/LU>

#include "ekf_slam/core/filter/ekf_slam.h"
#include "ekf_slam/core/filter/motion_models.h"
#include "ekf_slam/core/filter/observation_model.h"

namespace ekf_slam {
namespace test_pose_clones {

const RangeBearingModel kModel;

MotionStep translation(const EkfSlam& ekf, const Eigen::Vector2d& d, double sigma) {
  MotionStep s;
  s.pose = ekf.pose();
  s.pose.head<2>() += d;
  s.F = Eigen::Matrix3d::Identity();
  s.Q = Eigen::Matrix3d::Zero();
  s.Q(0, 0) = s.Q(1, 1) = sigma * sigma;
  return s;
}

MotionStep turn(const EkfSlam& ekf, double v, double w) {
  MotionStep s;
  const Eigen::Vector3d x = ekf.pose();
  s.pose = x + Eigen::Vector3d(v * std::cos(x(2)), v * std::sin(x(2)), w);
  s.F = Eigen::Matrix3d::Identity();
  s.F(0, 2) = -v * std::sin(x(2));
  s.F(1, 2) = v * std::cos(x(2));
  s.Q = Eigen::Vector3d(0.01, 0.01, 0.001).asDiagonal();
  return s;
}

// A filter with a few landmarks and correlations everywhere.
EkfSlam busyFilter() {
  EkfSlam ekf;
  ekf.reset(Eigen::Vector3d(1, 2, 0.3), Eigen::Vector3d(0.1, 0.2, 0.01).asDiagonal());
  const Eigen::Matrix2d R = Eigen::Vector2d(0.04, 0.001).asDiagonal();
  ekf.addLandmark({5, 0.2}, R, kModel);
  ekf.predict(turn(ekf, 1.0, 0.1));
  ekf.addLandmark({7, -0.4}, R, kModel);
  ekf.addLandmark({3, 1.0}, R, kModel);
  ekf.predict(turn(ekf, 1.0, -0.05));
  std::vector<Pairing> p = {{0, {4.2, 0.15}, R}, {1, {6.3, -0.5}, R}};
  EXPECT_TRUE(ekf.update(p, kModel));
  return ekf;
}

Eigen::MatrixXd full(const EkfSlam& ekf) { return ekf.covariance(); }

TEST(PoseClones, AddedAndRemovedLeavesTheStateExactly) {
  EkfSlam ekf = busyFilter();
  const Eigen::VectorXd x0 = ekf.mean();
  const Eigen::MatrixXd P0 = full(ekf);
  const CloneId a = ekf.addClone();
  const CloneId b = ekf.addClone();
  EXPECT_EQ(ekf.numClones(), 2u);
  EXPECT_EQ(ekf.mean().size(), x0.size() + 6);
  EXPECT_EQ(ekf.cloneRow(a), ekf.mapEnd());
  EXPECT_EQ(ekf.cloneRow(b), ekf.mapEnd() + 3);
  const Eigen::MatrixXd P1 = full(ekf);
  // A copy: the same mean, and cov(clone, .) = cov(pose, .).
  EXPECT_TRUE(ekf.clonePose(a).isApprox(ekf.pose()));
  EXPECT_TRUE(P1.block(ekf.cloneRow(a), 0, 3, x0.size()).isApprox(P0.topRows(3)));
  const Eigen::Matrix3d ab = P1.block(ekf.cloneRow(a), ekf.cloneRow(b), 3, 3);
  EXPECT_TRUE(ab.isApprox(P0.topLeftCorner<3, 3>()));
  EXPECT_TRUE(ekf.removeClone(a));
  EXPECT_FALSE(ekf.removeClone(a));
  EXPECT_TRUE(ekf.removeClone(b));
  EXPECT_EQ(ekf.mean(), x0);
  EXPECT_EQ(full(ekf), P0);
}

// A clone kept through predictions, updates, a landmark added and one removed is marginalised
// to exactly the state of the same steps without it.
TEST(PoseClones, ChangeNothingElseThroughEveryStep) {
  EkfSlam with = busyFilter(), without = busyFilter();
  with.addClone();
  const Eigen::Matrix2d R = Eigen::Vector2d(0.04, 0.001).asDiagonal();
  for (EkfSlam* e : {&with, &without}) {
    e->predict(turn(*e, 1.0, 0.2));
    std::vector<Pairing> p = {{2, {2.5, 1.1}, R}};
    ASSERT_TRUE(e->update(p, kModel));
    e->addLandmark({4, 0.3}, R, kModel);
    e->predict(turn(*e, 0.5, 0.0));
    ASSERT_TRUE(e->removeLandmark(1));
    e->insertLandmark({10, 10}, Eigen::Matrix2d::Identity(), 42);
  }
  with.addClone();
  for (EkfSlam* e : {&with, &without}) {
    std::vector<Pairing> p = {{0, {3.0, 0.4}, R}, {3, {4.0, 0.2}, R}};
    ASSERT_TRUE(e->update(p, kModel));
  }
  EXPECT_EQ(with.landmarkIds(), without.landmarkIds());
  EXPECT_EQ(with.numClones(), 2u);
  with.removeAllClones();
  EXPECT_LT((with.mean() - without.mean()).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_LT((full(with) - full(without)).cwiseAbs().maxCoeff(), 1e-12);
}

// The dense augmented EKF, written out: clone by J = [I 0], predict by blockdiag(F, I), update
// with H against the clone's rows. The EKF's clone rows must agree.
TEST(PoseClones, AnObservationAgainstACloneIsTheAugmentedEkfUpdate) {
  EkfSlam ekf = busyFilter();
  const CloneId c = ekf.addClone();
  const Eigen::VectorXd xa = ekf.mean();
  Eigen::MatrixXd Pa = full(ekf);
  const int n = static_cast<int>(xa.size());
  // Predict by hand.
  const MotionStep step = turn(ekf, 1.0, 0.3);
  Eigen::MatrixXd F = Eigen::MatrixXd::Identity(n, n);
  F.topLeftCorner<3, 3>() = step.F;
  Eigen::MatrixXd Q = Eigen::MatrixXd::Zero(n, n);
  Q.topLeftCorner<3, 3>() = step.Q;
  Eigen::VectorXd x = xa;
  x.head<3>() = step.pose;
  Eigen::MatrixXd P = F * Pa * F.transpose() + Q;
  ekf.predict(step);
  ASSERT_TRUE(ekf.mean().isApprox(x));
  ASSERT_TRUE(full(ekf).isApprox(P, 1e-12));
  // Update against the clone (landmark 1) and the current pose (landmark 0).
  const Eigen::Matrix2d R = Eigen::Vector2d(0.04, 0.001).asDiagonal();
  const std::vector<Pairing> pairings = {{1, {6.1, -0.3}, R, MeasurementKind::kRangeBearing, c},
                                         {0, {3.9, 0.1}, R}};
  Eigen::MatrixXd H = Eigen::MatrixXd::Zero(4, n);
  Eigen::VectorXd v(4);
  const int rows[2] = {ekf.cloneRow(c), 0};
  for (int i = 0; i < 2; ++i) {
    const int idx = ekf.indexOf(pairings[i].id);
    Matrix23d Hv;
    Eigen::Matrix2d Hm;
    const Eigen::Vector2d z_hat = kModel.predict(x.segment<3>(rows[i]), ekf.landmark(idx),
                                                 MeasurementKind::kRangeBearing, &Hv, &Hm);
    H.block<2, 3>(2 * i, rows[i]) = Hv;
    H.block<2, 2>(2 * i, ekf.stateRow(idx)) = Hm;
    v.segment<2>(2 * i) =
        RangeBearingModel::innovation(pairings[i].z, z_hat, MeasurementKind::kRangeBearing);
  }
  Eigen::MatrixXd S = H * P * H.transpose();
  S.block<2, 2>(0, 0) += R;
  S.block<2, 2>(2, 2) += R;
  const Eigen::MatrixXd K = P * H.transpose() * S.inverse();
  x += K * v;
  P -= K * S * K.transpose();
  ASSERT_TRUE(ekf.update(pairings, kModel));
  Eigen::VectorXd dx = ekf.mean() - x;
  dx(2) = std::remainder(dx(2), 2 * M_PI);
  EXPECT_LT(dx.cwiseAbs().maxCoeff(), 1e-10);
  EXPECT_LT((full(ekf) - P).cwiseAbs().maxCoeff(), 1e-10);
}

// Linear case (known heading, Cartesian sightings): a landmark seen from five poses gets the
// same estimate whether it is created at its first sighting and updated at each later one, or
// created at its last sighting and updated with the earlier ones against their clones.
TEST(PoseClones, DelayedSightingsGiveTheImmediateEstimate) {
  const Eigen::Vector2d landmark(6, 2);
  const Eigen::Matrix2d R = Eigen::Vector2d(0.05, 0.08).asDiagonal();
  const std::vector<Eigen::Vector2d> noise = {
      {0.1, -0.2}, {-0.05, 0.1}, {0.2, 0.0}, {0, 0.1}, {-0.1, -0.1}};
  const auto start = [] {
    EkfSlam e;
    e.reset(Eigen::Vector3d::Zero(), Eigen::Vector3d(0.01, 0.01, 0).asDiagonal());
    return e;
  };
  EkfSlam now = start(), delayed = start();
  std::vector<Pairing> kept;
  LandmarkId id = kNoLandmark;
  Eigen::Vector2d truth_pose(0, 0);
  for (std::size_t k = 0; k < noise.size(); ++k) {
    if (k > 0) {
      truth_pose += Eigen::Vector2d(1.0, 0.0);
      for (EkfSlam* e : {&now, &delayed}) e->predict(translation(*e, {1.0, 0.0}, 0.1));
    }
    const Eigen::Vector2d z = landmark - truth_pose + noise[k];
    if (k == 0) {
      id = now.addLandmark(z, R, kModel, MeasurementKind::kCartesian);
    } else {
      ASSERT_TRUE(now.update({{id, z, R, MeasurementKind::kCartesian}}, kModel));
    }
    if (k + 1 < noise.size()) {
      kept.push_back({kNoLandmark, z, R, MeasurementKind::kCartesian, delayed.addClone()});
    } else {
      const LandmarkId d = delayed.addLandmark(z, R, kModel, MeasurementKind::kCartesian);
      for (Pairing& p : kept) p.id = d;
      ASSERT_TRUE(delayed.update(kept, kModel));
      delayed.removeAllClones();
    }
  }
  EXPECT_LT((now.mean() - delayed.mean()).cwiseAbs().maxCoeff(), 1e-9);
  EXPECT_LT((full(now) - full(delayed)).cwiseAbs().maxCoeff(), 1e-9);
}

// EkfSlam::innovation: the innovation and S of one pairing, from the pose or a clone, are those the
// update weighs (its NIS), and it changes nothing.
TEST(PoseClones, TheInnovationOfOnePairingIsTheOneTheUpdateWeighs) {
  EkfSlam ekf = busyFilter();
  const CloneId c = ekf.addClone();
  ekf.predict(turn(ekf, 1.0, 0.2));
  const Eigen::Matrix2d R = Eigen::Vector2d(0.04, 0.001).asDiagonal();
  for (const Pairing& p :
       {Pairing{2, {2.5, 1.1}, R}, Pairing{1, {6.0, -0.3}, R, MeasurementKind::kRangeBearing, c}}) {
    const Eigen::VectorXd x0 = ekf.mean();
    Eigen::Vector2d v;
    Eigen::Matrix2d S;
    ASSERT_TRUE(ekf.innovation(p, kModel, &v, &S));
    EXPECT_EQ(ekf.mean(), x0);
    EkfSlam updated = ekf;
    double nis = 0.0;
    ASSERT_TRUE(updated.update({p}, kModel, &nis));
    EXPECT_NEAR(v.dot(S.inverse() * v), nis, 1e-9 * std::max(1.0, nis));
    EXPECT_GT(nis, 0.1);  // a real innovation, not a trivially equal zero
  }
  Eigen::Vector2d v;
  Eigen::Matrix2d S;
  EXPECT_FALSE(ekf.innovation({0, {4, 0}, R, MeasurementKind::kRangeBearing, 99}, kModel, &v, &S));
  EXPECT_FALSE(ekf.innovation({77, {4, 0}, R}, kModel, &v, &S));
}

TEST(PoseClones, UnknownClonesAreRefused) {
  EkfSlam ekf = busyFilter();
  const Eigen::VectorXd x0 = ekf.mean();
  const Eigen::Matrix2d R = Eigen::Matrix2d::Identity();
  EXPECT_FALSE(ekf.update({{0, {4, 0}, R, MeasurementKind::kRangeBearing, 7}}, kModel));
  EXPECT_EQ(ekf.mean(), x0);
  EXPECT_EQ(ekf.cloneRow(7), -1);
  EXPECT_FALSE(ekf.clonePose(7).allFinite());
  // setState and reset drop the clones.
  ekf.addClone();
  ekf.reset();
  EXPECT_EQ(ekf.numClones(), 0u);
}

}  // namespace test_pose_clones
}  // namespace ekf_slam
