// EkfSlam: prediction, batch update, landmark initialisation and removal against hand-computed
// values and a straightforward dense reference, plus robustness (rejections, PSD covariance).
#include <cmath>
#include <cstring>
#include <limits>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <Eigen/Eigenvalues>

#include "ekf_slam/core/common/angles.h"
#include "ekf_slam/core/filter/ekf_slam.h"
#include "ekf_slam/core/filter/motion_models.h"
#include "ekf_slam/core/filter/observation_model.h"

namespace ekf_slam {
namespace test_ekf_slam {

bool bitwiseEqual(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b) {
  return a.rows() == b.rows() && a.cols() == b.cols() &&
         std::memcmp(a.data(), b.data(), sizeof(double) * a.size()) == 0;
}

double minEigenvalue(const Eigen::MatrixXd& P) {
  return Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(P, Eigen::EigenvaluesOnly)
      .eigenvalues()
      .minCoeff();
}

// Random SPD matrix with eigenvalues in [lo, hi].
Eigen::MatrixXd randomSpd(int n, double lo, double hi, std::mt19937* rng) {
  std::uniform_real_distribution<double> u(-1.0, 1.0), e(lo, hi);
  Eigen::MatrixXd A(n, n);
  for (int i = 0; i < n * n; ++i) A(i) = u(*rng);
  const Eigen::HouseholderQR<Eigen::MatrixXd> qr(A);
  const Eigen::MatrixXd Q = qr.householderQ();
  Eigen::VectorXd d(n);
  for (int i = 0; i < n; ++i) d(i) = e(*rng);
  const Eigen::MatrixXd P = Q * d.asDiagonal() * Q.transpose();
  return 0.5 * (P + P.transpose());  // exactly symmetric, as the filter keeps it
}

// The textbook EKF update with a dense H: K = P H^T S^-1, x += K v, P -= K S K^T.
struct DenseResult {
  Eigen::VectorXd x;
  Eigen::MatrixXd P;
  double nis;
};

DenseResult denseUpdate(const Eigen::VectorXd& x, const Eigen::MatrixXd& P,
                        const std::vector<int>& indices, const std::vector<Eigen::Vector2d>& z,
                        const std::vector<Eigen::Matrix2d>& R, const RangeBearingModel& model) {
  const int m = static_cast<int>(indices.size());
  const int n = static_cast<int>(x.size());
  Eigen::MatrixXd H = Eigen::MatrixXd::Zero(2 * m, n);
  Eigen::MatrixXd Rb = Eigen::MatrixXd::Zero(2 * m, 2 * m);
  Eigen::VectorXd v(2 * m);
  for (int i = 0; i < m; ++i) {
    Matrix23d Hv;
    Eigen::Matrix2d Hm;
    const int row = 3 + 2 * indices[i];
    const Eigen::Vector2d zh = model.predict(x.head<3>(), x.segment<2>(row), &Hv, &Hm);
    H.block<2, 3>(2 * i, 0) = Hv;
    H.block<2, 2>(2 * i, row) = Hm;
    Rb.block<2, 2>(2 * i, 2 * i) = R[i];
    v.segment<2>(2 * i) = RangeBearingModel::innovation(z[i], zh);
  }
  const Eigen::MatrixXd S = H * P * H.transpose() + Rb;
  const Eigen::MatrixXd K = P * H.transpose() * S.inverse();
  DenseResult r;
  r.x = x + K * v;
  r.x(2) = wrapAngle(r.x(2));
  r.P = P - K * S * K.transpose();
  r.nis = v.dot(S.inverse() * v);
  return r;
}

// A filter with a correlated random state: pose plus `n` landmarks around the robot.
EkfSlam randomFilter(int n, std::mt19937* rng) {
  std::uniform_real_distribution<double> pos(-30.0, 30.0);
  Eigen::VectorXd x(3 + 2 * n);
  x(0) = 1.0;
  x(1) = -2.0;
  x(2) = 0.4;
  for (int i = 0; i < 2 * n; ++i) x(3 + i) = pos(*rng);
  const Eigen::MatrixXd P = randomSpd(3 + 2 * n, 0.01, 0.5, rng);
  std::vector<LandmarkId> ids;
  for (int i = 0; i < n; ++i) ids.push_back(10 + 3 * i);  // not 0..n-1 on purpose
  EkfSlam ekf;
  ekf.setState(x, P, ids);
  return ekf;
}

void expectSymmetricPsd(const Eigen::MatrixXd& P) {
  EXPECT_EQ((P - P.transpose()).cwiseAbs().maxCoeff(), 0.0);
  EXPECT_GE(minEigenvalue(P), -1e-9);
}

// --- basics ------------------------------------------------------------------------------------

TEST(EkfSlam, ResetAndEmpty) {
  EkfSlam ekf;
  EXPECT_EQ(ekf.mean().size(), 3);
  EXPECT_EQ(ekf.numLandmarks(), 0u);
  ekf.reset(Eigen::Vector3d(1, 2, 3 * M_PI), Eigen::Matrix3d::Identity());
  EXPECT_NEAR(ekf.pose()(2), M_PI, 1e-12);
  EXPECT_EQ(ekf.poseCovariance(), Eigen::Matrix3d::Identity());
  double nis = -1;
  EXPECT_TRUE(ekf.update({}, RangeBearingModel(), &nis));
  EXPECT_EQ(nis, 0.0);
  EXPECT_EQ(ekf.indexOf(0), -1);
  EXPECT_FALSE(ekf.removeLandmark(0));
}

TEST(EkfSlam, SetStateValidates) {
  EkfSlam ekf;
  EXPECT_THROW(ekf.setState(Eigen::VectorXd::Zero(5), Eigen::MatrixXd::Identity(5, 5), {1, 2}),
               std::invalid_argument);
  EXPECT_THROW(ekf.setState(Eigen::VectorXd::Zero(5), Eigen::MatrixXd::Identity(4, 4), {1}),
               std::invalid_argument);
  EXPECT_THROW(ekf.setState(Eigen::VectorXd::Zero(7), Eigen::MatrixXd::Identity(7, 7), {4, 4}),
               std::invalid_argument);
  EXPECT_THROW(ekf.setState(Eigen::VectorXd::Zero(5), Eigen::MatrixXd::Identity(5, 5), {-3}),
               std::invalid_argument);
  ekf.setState(Eigen::VectorXd::Zero(7), Eigen::MatrixXd::Identity(7, 7), {7, 2});
  EXPECT_EQ(ekf.indexOf(7), 0);
  EXPECT_EQ(ekf.indexOf(2), 1);
  // New ids do not collide with the loaded ones.
  const LandmarkId id =
      ekf.addLandmark(Eigen::Vector2d(1, 0), Eigen::Matrix2d::Identity(), RangeBearingModel());
  EXPECT_EQ(id, 8);
}

TEST(EkfSlam, InsertLandmark) {
  EkfSlam ekf;
  ekf.reset(Eigen::Vector3d::Zero(), Eigen::Matrix3d::Identity());
  EXPECT_EQ(ekf.insertLandmark(Eigen::Vector2d(1, 2), Eigen::Matrix2d::Identity() * 2, 5), 5);
  EXPECT_EQ(ekf.insertLandmark(Eigen::Vector2d(3, 4), Eigen::Matrix2d::Identity(), 5), 6);
  EXPECT_EQ(ekf.insertLandmark(Eigen::Vector2d(5, 6), Eigen::Matrix2d::Identity()), 7);
  EXPECT_EQ(ekf.landmark(1), Eigen::Vector2d(3, 4));
  EXPECT_EQ(ekf.landmarkCovariance(0), Eigen::Matrix2d::Identity() * 2);
  EXPECT_EQ(ekf.covariance().block(0, 3, 3, 6), Eigen::MatrixXd::Zero(3, 6));
  EXPECT_EQ(ekf.covariance().block(3, 5, 2, 4), Eigen::MatrixXd::Zero(2, 4));
}

// --- prediction --------------------------------------------------------------------------------

TEST(EkfSlam, PredictTouchesOnlyPoseRowsAndColumns) {
  std::mt19937 rng(1);
  EkfSlam ekf = randomFilter(5, &rng);
  const Eigen::VectorXd x0 = ekf.mean();
  const Eigen::MatrixXd P0 = ekf.covariance();
  const TwistModel model;
  const MotionStep step = model.step(ekf.pose(), Eigen::Vector2d(2.0, 0.3), 0.5);
  ASSERT_TRUE(ekf.predict(step));
  const Eigen::MatrixXd& P = ekf.covariance();
  const int n = static_cast<int>(P.rows());
  // Dense reference: F_full P F_full^T + Q_full.
  Eigen::MatrixXd Ff = Eigen::MatrixXd::Identity(n, n);
  Ff.topLeftCorner<3, 3>() = step.F;
  Eigen::MatrixXd ref = Ff * P0 * Ff.transpose();
  ref.topLeftCorner<3, 3>() += step.Q;
  EXPECT_LT((P - ref).cwiseAbs().maxCoeff(), 1e-12);
  // The map block is not even rewritten.
  EXPECT_TRUE(bitwiseEqual(P.bottomRightCorner(n - 3, n - 3), P0.bottomRightCorner(n - 3, n - 3)));
  EXPECT_EQ((P - P.transpose()).cwiseAbs().maxCoeff(), 0.0);
  EXPECT_EQ(ekf.pose(), step.pose);
  EXPECT_TRUE(bitwiseEqual(ekf.mean().tail(n - 3), x0.tail(n - 3)));
}

TEST(EkfSlam, PredictHandComputed) {
  // Pose cov I, one landmark cov I correlated 0.5 with x; F shears yaw into y.
  Eigen::VectorXd x(5);
  x << 0, 0, 0, 4, 0;
  Eigen::MatrixXd P = Eigen::MatrixXd::Identity(5, 5);
  P(0, 3) = P(3, 0) = 0.5;
  EkfSlam ekf;
  ekf.setState(x, P, {0});
  MotionStep s;
  s.pose = Eigen::Vector3d(1, 0, 0);
  s.F << 1, 0, 0, 0, 1, 2, 0, 0, 1;
  s.Q = Eigen::Matrix3d::Identity() * 0.1;
  ASSERT_TRUE(ekf.predict(s));
  Eigen::Matrix3d Pvv;
  Pvv << 1.1, 0, 0, 0, 5.1, 2, 0, 2, 1.1;  // F F^T + Q
  EXPECT_LT((ekf.poseCovariance() - Pvv).norm(), 1e-15);
  EXPECT_DOUBLE_EQ(ekf.covariance()(0, 3), 0.5);
  EXPECT_DOUBLE_EQ(ekf.covariance()(3, 0), 0.5);
  EXPECT_DOUBLE_EQ(ekf.covariance()(1, 3), 0.0);
}

TEST(EkfSlam, PredictRejectsNonFinite) {
  std::mt19937 rng(2);
  EkfSlam ekf = randomFilter(2, &rng);
  const Eigen::VectorXd x0 = ekf.mean();
  const Eigen::MatrixXd P0 = ekf.covariance();
  MotionStep s;
  s.pose = Eigen::Vector3d(1, 2, 3);
  s.F = Eigen::Matrix3d::Identity();
  s.Q = Eigen::Matrix3d::Identity();
  s.Q(1, 1) = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(ekf.predict(s));
  s.Q(1, 1) = 1;
  s.pose(0) = std::numeric_limits<double>::infinity();
  EXPECT_FALSE(ekf.predict(s));
  EXPECT_TRUE(bitwiseEqual(ekf.mean(), x0));
  EXPECT_TRUE(bitwiseEqual(ekf.covariance(), P0));
}

// --- update ------------------------------------------------------------------------------------

TEST(EkfSlam, UpdateHandComputedOneLandmark) {
  // Pose known exactly at the origin; landmark at (10, 0) with cov I. R = diag(1, 0.01).
  // H_m = diag(1, 1/10) -> S = diag(2, 0.02), K_m = diag(0.5, 5).
  // z = (11, 0.05) -> v = (1, 0.05), m += (0.5, 0.25), P_mm = diag(0.5, 0.5), NIS = 0.625.
  EkfSlam ekf;
  Eigen::VectorXd x(5);
  x << 0, 0, 0, 10, 0;
  Eigen::MatrixXd P = Eigen::MatrixXd::Zero(5, 5);
  P.bottomRightCorner<2, 2>().setIdentity();
  ekf.setState(x, P, {42});
  double nis = 0;
  const Eigen::Matrix2d R = Eigen::Vector2d(1, 0.01).asDiagonal();
  ASSERT_TRUE(ekf.update({{42, Eigen::Vector2d(11, 0.05), R}}, RangeBearingModel(), &nis));
  EXPECT_NEAR(nis, 0.625, 1e-12);
  EXPECT_NEAR(ekf.landmark(0)(0), 10.5, 1e-12);
  EXPECT_NEAR(ekf.landmark(0)(1), 0.25, 1e-12);
  EXPECT_LT((ekf.landmarkCovariance(0) - 0.5 * Eigen::Matrix2d::Identity()).norm(), 1e-12);
  EXPECT_LT(ekf.pose().norm(), 1e-15);
  EXPECT_LT(ekf.poseCovariance().norm(), 1e-15);
}

TEST(EkfSlam, UpdateHandComputedPoseOnly) {
  // Landmark known exactly at (10, 0), robot at the origin with pose cov diag(1, 1, 0).
  // H_v = [-1 0 0; 0 -0.1 -1] -> S = diag(1 + 1, 0.01 + 0.01), K_v = [-0.5 0; 0 -5; 0 0].
  // z = (9, 0.05) -> v = (-1, 0.05): pose += (0.5, -0.25, 0).
  EkfSlam ekf;
  Eigen::VectorXd x(5);
  x << 0, 0, 0, 10, 0;
  Eigen::MatrixXd P = Eigen::MatrixXd::Zero(5, 5);
  P(0, 0) = P(1, 1) = 1;
  ekf.setState(x, P, {0});
  const Eigen::Matrix2d R = Eigen::Vector2d(1, 0.01).asDiagonal();
  ASSERT_TRUE(ekf.update({{0, Eigen::Vector2d(9, 0.05), R}}, RangeBearingModel()));
  EXPECT_NEAR(ekf.pose()(0), 0.5, 1e-12);
  EXPECT_NEAR(ekf.pose()(1), -0.25, 1e-12);
  EXPECT_NEAR(ekf.pose()(2), 0.0, 1e-15);
  EXPECT_NEAR(ekf.poseCovariance()(0, 0), 0.5, 1e-12);
  EXPECT_NEAR(ekf.poseCovariance()(1, 1), 0.5, 1e-12);
  EXPECT_LT((ekf.landmark(0) - Eigen::Vector2d(10, 0)).norm(), 1e-15);
}

TEST(EkfSlam, BatchUpdateMatchesDenseReference) {
  std::mt19937 rng(3);
  const RangeBearingModel model(Eigen::Vector3d(3.78, 0.5, 0.1));
  for (int trial = 0; trial < 5; ++trial) {
    EkfSlam ekf = randomFilter(6, &rng);
    const Eigen::VectorXd x0 = ekf.mean();
    const Eigen::MatrixXd P0 = ekf.covariance();
    std::normal_distribution<double> noise(0.0, 0.1);
    std::vector<Pairing> pairings;
    std::vector<int> indices;
    std::vector<Eigen::Vector2d> zs;
    std::vector<Eigen::Matrix2d> Rs;
    for (int idx : {4, 1, 3}) {
      Eigen::Vector2d z = model.predict(ekf.pose(), ekf.landmark(idx));
      z(0) += noise(rng);
      z(1) = wrapAngle(z(1) + 0.1 * noise(rng));
      const Eigen::Matrix2d R = Eigen::Vector2d(0.04, 0.001).asDiagonal();
      pairings.push_back({ekf.landmarkIds()[idx], z, R});
      indices.push_back(idx);
      zs.push_back(z);
      Rs.push_back(R);
    }
    double nis = 0;
    ASSERT_TRUE(ekf.update(pairings, model, &nis));
    const DenseResult ref = denseUpdate(x0, P0, indices, zs, Rs, model);
    EXPECT_LT((ekf.mean() - ref.x).cwiseAbs().maxCoeff(), 1e-9);
    EXPECT_LT((ekf.covariance() - ref.P).cwiseAbs().maxCoeff(), 1e-9);
    EXPECT_NEAR(nis, ref.nis, 1e-8 * (1 + ref.nis));
    expectSymmetricPsd(ekf.covariance());
    // It actually moved.
    EXPECT_GT((ekf.mean() - x0).norm(), 1e-4);
  }
}

TEST(EkfSlam, BatchOfTwoEqualsTwoSequentialUpdates) {
  // With H fixed (the linear case) a batch update equals sequential updates exactly: check that
  // on the dense formulas, then that the filter's batch matches, and that the filter's own
  // sequential updates (which relinearise) agree closely when the correction is small.
  std::mt19937 rng(4);
  const RangeBearingModel model;
  EkfSlam ekf = randomFilter(4, &rng);
  const Eigen::VectorXd x0 = ekf.mean();
  const Eigen::MatrixXd P0 = ekf.covariance() * 1e-4;  // small: nearly linear
  ekf.setState(x0, P0, ekf.landmarkIds());
  const Eigen::Matrix2d R = Eigen::Vector2d(1e-4, 1e-6).asDiagonal();
  Eigen::Vector2d z0 = model.predict(x0.head<3>(), x0.segment<2>(3 + 2 * 0));
  Eigen::Vector2d z2 = model.predict(x0.head<3>(), x0.segment<2>(3 + 2 * 2));
  z0 += Eigen::Vector2d(0.01, 0.001);
  z2 += Eigen::Vector2d(-0.01, 0.002);

  // Linear KF with the Jacobians frozen at x0.
  const int n = static_cast<int>(x0.size());
  auto rowsOf = [&](int idx) {
    Matrix23d Hv;
    Eigen::Matrix2d Hm;
    model.predict(x0.head<3>(), x0.segment<2>(3 + 2 * idx), &Hv, &Hm);
    Eigen::MatrixXd H = Eigen::MatrixXd::Zero(2, n);
    H.leftCols<3>() = Hv;
    H.middleCols<2>(3 + 2 * idx) = Hm;
    return H;
  };
  const Eigen::MatrixXd H0 = rowsOf(0), H2 = rowsOf(2);
  const Eigen::Vector2d v0 =
      RangeBearingModel::innovation(z0, model.predict(x0.head<3>(), x0.segment<2>(3)));
  const Eigen::Vector2d v2 =
      RangeBearingModel::innovation(z2, model.predict(x0.head<3>(), x0.segment<2>(7)));
  Eigen::VectorXd xs = x0;
  Eigen::MatrixXd Ps = P0;
  for (int k = 0; k < 2; ++k) {
    const Eigen::MatrixXd& H = k == 0 ? H0 : H2;
    // Linear measurement: the innovation at xs is the one at x0 minus H (xs - x0).
    const Eigen::Vector2d v = (k == 0 ? v0 : v2) - H * (xs - x0);
    const Eigen::Matrix2d S = H * Ps * H.transpose() + R;
    const Eigen::MatrixXd K = Ps * H.transpose() * S.inverse();
    xs += K * v;
    Ps -= K * S * K.transpose();
  }
  const DenseResult batch = denseUpdate(x0, P0, {0, 2}, {z0, z2}, {R, R}, model);
  EXPECT_LT((batch.x - xs).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_LT((batch.P - Ps).cwiseAbs().maxCoeff(), 1e-12);

  ASSERT_TRUE(ekf.update({{ekf.landmarkIds()[0], z0, R}, {ekf.landmarkIds()[2], z2, R}}, model));
  EXPECT_LT((ekf.mean() - batch.x).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_LT((ekf.covariance() - batch.P).cwiseAbs().maxCoeff(), 1e-12);

  EkfSlam seq;
  seq.setState(x0, P0, ekf.landmarkIds());
  ASSERT_TRUE(seq.update({{ekf.landmarkIds()[0], z0, R}}, model));
  ASSERT_TRUE(seq.update({{ekf.landmarkIds()[2], z2, R}}, model));
  EXPECT_LT((seq.mean() - ekf.mean()).cwiseAbs().maxCoeff(), 1e-5);
  EXPECT_LT((seq.covariance() - ekf.covariance()).cwiseAbs().maxCoeff(), 1e-7);
}

TEST(EkfSlam, UpdateAcrossBearingWrap) {
  // Landmark straight behind the robot: predicted bearing ~ +pi, observed ~ -pi. The innovation
  // must be small, so the update barely moves the state.
  EkfSlam ekf;
  Eigen::VectorXd x(5);
  x << 0, 0, 0, -10, 0.01;  // bearing pi - 0.001
  Eigen::MatrixXd P = Eigen::MatrixXd::Identity(5, 5) * 0.01;
  ekf.setState(x, P, {0});
  const Eigen::Matrix2d R = Eigen::Vector2d(0.01, 1e-4).asDiagonal();
  double nis = 0;
  ASSERT_TRUE(ekf.update({{0, Eigen::Vector2d(10, -M_PI + 0.001), R}}, RangeBearingModel(), &nis));
  EXPECT_LT(nis, 1.0);
  EXPECT_LT((ekf.mean() - x).norm(), 0.05);
  // The landmark moved towards the observation, i.e. across the -x axis to negative y.
  EXPECT_LT(ekf.landmark(0)(1), 0.01);
}

TEST(EkfSlam, UpdateKeepsYawWrapped) {
  EkfSlam ekf;
  Eigen::VectorXd x(5);
  x << 0, 0, M_PI - 1e-3, -10, 0;
  Eigen::MatrixXd P = Eigen::MatrixXd::Zero(5, 5);
  P(2, 2) = 0.1;
  ekf.setState(x, P, {0});
  // Observed bearing says the robot's yaw is larger than pi - 1e-3 by 0.01.
  const Eigen::Vector2d z_hat = RangeBearingModel().predict(x.head<3>(), x.tail<2>());
  ASSERT_TRUE(ekf.update({{0, Eigen::Vector2d(z_hat(0), wrapAngle(z_hat(1) - 0.01)),
                           Eigen::Vector2d(0.01, 1e-8).asDiagonal()}},
                         RangeBearingModel()));
  EXPECT_GT(ekf.pose()(2), -M_PI);
  EXPECT_LE(ekf.pose()(2), M_PI);
  EXPECT_NEAR(wrapAngle(ekf.pose()(2) - (M_PI - 1e-3 + 0.01)), 0.0, 1e-6);
}

TEST(EkfSlam, UpdateRejectsBadInputLeavingStateUnchanged) {
  std::mt19937 rng(5);
  EkfSlam ekf = randomFilter(3, &rng);
  const Eigen::VectorXd x0 = ekf.mean();
  const Eigen::MatrixXd P0 = ekf.covariance();
  const RangeBearingModel model;
  const LandmarkId a = ekf.landmarkIds()[0], b = ekf.landmarkIds()[1];
  const Eigen::Vector2d za = model.predict(ekf.pose(), ekf.landmark(0));
  const Eigen::Vector2d zb = model.predict(ekf.pose(), ekf.landmark(1));
  const Eigen::Matrix2d R = Eigen::Matrix2d::Identity() * 0.01;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  double nis = 123;

  // S not positive definite (negative measurement noise swamps H P H^T).
  EXPECT_FALSE(ekf.update({{a, za, R}, {b, zb, -1e3 * Eigen::Matrix2d::Identity()}}, model, &nis));
  // NaN observation, NaN noise, infinite observation.
  EXPECT_FALSE(ekf.update({{a, za, R}, {b, Eigen::Vector2d(nan, 0.1), R}}, model, &nis));
  EXPECT_FALSE(ekf.update({{a, za, Eigen::Matrix2d::Constant(nan)}}, model, &nis));
  EXPECT_FALSE(ekf.update({{a, Eigen::Vector2d(std::numeric_limits<double>::infinity(), 0), R}},
                          model, &nis));
  // Unknown id.
  EXPECT_FALSE(ekf.update({{a, za, R}, {999, zb, R}}, model, &nis));
  EXPECT_TRUE(bitwiseEqual(ekf.mean(), x0));
  EXPECT_TRUE(bitwiseEqual(ekf.covariance(), P0));
  EXPECT_EQ(nis, 123);

  // Landmark exactly at the sensor: the Jacobian is undefined.
  EkfSlam degenerate;
  Eigen::VectorXd x(5);
  x << 1, 1, 0, 1, 1;
  degenerate.setState(x, Eigen::MatrixXd::Identity(5, 5), {0});
  EXPECT_FALSE(degenerate.update({{0, Eigen::Vector2d(1, 0), R}}, model));
  EXPECT_TRUE(bitwiseEqual(degenerate.mean(), x));
  EXPECT_TRUE(degenerate.mean().allFinite() && degenerate.covariance().allFinite());

  // And the filter still works afterwards.
  EXPECT_TRUE(ekf.update({{a, za, R}}, model));
}

// --- augmentation and removal ------------------------------------------------------------------

TEST(EkfSlam, AddLandmarkHandComputed) {
  // Pose (1, 2, pi/2), cov diag(0.1, 0.2, 0.3); z = (2, 0), R = diag(0.01, 1e-4): m = (1, 4).
  // G_v = [1 0 -2; 0 1 0], G_z = [0 -2; 1 0].
  // P_mm = G_v P_vv G_v^T + G_z R G_z^T = diag(0.1 + 1.2, 0.2) + diag(4e-4, 0.01).
  // P_mv = G_v P_vv = [0.1 0 -0.6; 0 0.2 0].
  EkfSlam ekf;
  ekf.reset(Eigen::Vector3d(1, 2, M_PI / 2), Eigen::Vector3d(0.1, 0.2, 0.3).asDiagonal());
  const LandmarkId id = ekf.addLandmark(
      Eigen::Vector2d(2, 0), Eigen::Vector2d(0.01, 1e-4).asDiagonal(), RangeBearingModel());
  EXPECT_EQ(id, 0);
  EXPECT_EQ(ekf.indexOf(id), 0);
  ASSERT_EQ(ekf.mean().size(), 5);
  EXPECT_NEAR(ekf.landmark(0)(0), 1.0, 1e-12);
  EXPECT_NEAR(ekf.landmark(0)(1), 4.0, 1e-12);
  Eigen::Matrix2d Pmm;
  Pmm << 1.3004, 0, 0, 0.21;
  EXPECT_LT((ekf.landmarkCovariance(0) - Pmm).norm(), 1e-12);
  Eigen::Matrix<double, 2, 3> Pmv;
  Pmv << 0.1, 0, -0.6, 0, 0.2, 0;
  EXPECT_LT((ekf.covariance().block<2, 3>(3, 0) - Pmv).norm(), 1e-12);
  EXPECT_LT((ekf.covariance().block<3, 2>(0, 3) - Pmv.transpose()).norm(), 1e-12);
}

TEST(EkfSlam, AddLandmarkMatchesDenseAugmentation) {
  std::mt19937 rng(6);
  EkfSlam ekf = randomFilter(3, &rng);
  const Eigen::VectorXd x0 = ekf.mean();
  const Eigen::MatrixXd P0 = ekf.covariance();
  const RangeBearingModel model(Eigen::Vector3d(3.78, 0.5, -0.3));
  const Eigen::Vector2d z(12.0, -0.7);
  Eigen::Matrix2d R;
  R << 0.04, 0.001, 0.001, 0.002;
  const LandmarkId id = ekf.addLandmark(z, R, model);
  EXPECT_EQ(id, 17);  // ids 10, 13, 16 were loaded
  const int n = static_cast<int>(x0.size());
  Matrix23d Gv;
  Eigen::Matrix2d Gz;
  const Eigen::Vector2d m = model.inverse(x0.head<3>(), z, &Gv, &Gz);
  // P' = J diag(P, R) J^T, J = [I 0; G_v 0 G_z].
  Eigen::MatrixXd J = Eigen::MatrixXd::Zero(n + 2, n + 2);
  J.topLeftCorner(n, n).setIdentity();
  J.block<2, 3>(n, 0) = Gv;
  J.block<2, 2>(n, n) = Gz;
  Eigen::MatrixXd B = Eigen::MatrixXd::Zero(n + 2, n + 2);
  B.topLeftCorner(n, n) = P0;
  B.bottomRightCorner<2, 2>() = R;
  const Eigen::MatrixXd ref = J * B * J.transpose();
  EXPECT_LT((ekf.covariance() - ref).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_TRUE(bitwiseEqual(ekf.covariance().topLeftCorner(n, n), P0));
  EXPECT_TRUE(bitwiseEqual(ekf.mean().head(n), x0));
  EXPECT_EQ(ekf.landmark(3), m);
  EXPECT_EQ((ekf.covariance() - ekf.covariance().transpose()).cwiseAbs().maxCoeff(), 0.0);
  // The observation predicted back from the new landmark is z.
  const Eigen::Vector2d z2 = model.predict(ekf.pose(), ekf.landmark(3));
  EXPECT_LT((z2 - z).norm(), 1e-12);
}

TEST(EkfSlam, AddLandmarkRejectsNonFinite) {
  EkfSlam ekf;
  ekf.reset(Eigen::Vector3d::Zero(), Eigen::Matrix3d::Identity());
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(
      ekf.addLandmark(Eigen::Vector2d(nan, 0), Eigen::Matrix2d::Identity(), RangeBearingModel()),
      kNoLandmark);
  EXPECT_EQ(
      ekf.addLandmark(Eigen::Vector2d(1, 0), Eigen::Matrix2d::Constant(nan), RangeBearingModel()),
      kNoLandmark);
  EXPECT_EQ(ekf.numLandmarks(), 0u);
  EXPECT_EQ(ekf.mean().size(), 3);
  EXPECT_EQ(
      ekf.addLandmark(Eigen::Vector2d(1, 0), Eigen::Matrix2d::Identity(), RangeBearingModel()), 0);
}

TEST(EkfSlam, RemoveKeepsOtherIdsAndValues) {
  std::mt19937 rng(7);
  EkfSlam ekf = randomFilter(5, &rng);  // ids 10 13 16 19 22
  const Eigen::VectorXd x0 = ekf.mean();
  const Eigen::MatrixXd P0 = ekf.covariance();
  ASSERT_TRUE(ekf.removeLandmark(16));  // the middle one
  EXPECT_FALSE(ekf.removeLandmark(16));
  EXPECT_FALSE(ekf.contains(16));
  EXPECT_EQ(ekf.numLandmarks(), 4u);
  EXPECT_EQ(ekf.landmarkIds(), (std::vector<LandmarkId>{10, 13, 19, 22}));
  EXPECT_EQ(ekf.indexOf(10), 0);
  EXPECT_EQ(ekf.indexOf(13), 1);
  EXPECT_EQ(ekf.indexOf(19), 2);
  EXPECT_EQ(ekf.indexOf(22), 3);
  // Kept state rows, in order: pose, lm 0, lm 1, lm 3, lm 4.
  const std::vector<int> keep = {0, 1, 2, 3, 4, 5, 6, 9, 10, 11, 12};
  ASSERT_EQ(ekf.mean().size(), static_cast<Eigen::Index>(keep.size()));
  for (std::size_t i = 0; i < keep.size(); ++i) {
    EXPECT_EQ(ekf.mean()(i), x0(keep[i]));
    for (std::size_t j = 0; j < keep.size(); ++j) {
      EXPECT_EQ(ekf.covariance()(i, j), P0(keep[i], keep[j]));
    }
  }
  // Remove the last and the first too; a new landmark gets a fresh id.
  ASSERT_TRUE(ekf.removeLandmark(22));
  ASSERT_TRUE(ekf.removeLandmark(10));
  EXPECT_EQ(ekf.landmarkIds(), (std::vector<LandmarkId>{13, 19}));
  EXPECT_EQ(ekf.landmark(1), x0.segment<2>(3 + 2 * 3));
  EXPECT_EQ(ekf.indexOf(19), 1);
  const LandmarkId id =
      ekf.addLandmark(Eigen::Vector2d(5, 0.1), Eigen::Matrix2d::Identity(), RangeBearingModel());
  EXPECT_EQ(id, 23);
  EXPECT_EQ(ekf.indexOf(id), 2);
  ASSERT_TRUE(ekf.removeLandmark(13));
  ASSERT_TRUE(ekf.removeLandmark(19));
  ASSERT_TRUE(ekf.removeLandmark(23));
  EXPECT_EQ(ekf.mean().size(), 3);
  EXPECT_TRUE(bitwiseEqual(ekf.covariance(), P0.topLeftCorner(3, 3)));
}

// --- long random run ---------------------------------------------------------------------------

TEST(EkfSlam, RandomSequenceKeepsCovarianceSymmetricPsd) {
  std::mt19937 rng(8);
  std::uniform_real_distribution<double> uni(-1.0, 1.0);
  std::normal_distribution<double> gauss(0.0, 1.0);
  // True world: 40 landmarks in a 60 m square; robot drives circles with the twist model.
  std::vector<Eigen::Vector2d> world;
  for (int i = 0; i < 40; ++i) world.emplace_back(30 * uni(rng), 30 * uni(rng));
  const TwistModel motion;
  const RangeBearingModel sensor(Eigen::Vector3d(0.5, 0.1, 0.05));
  const Eigen::Matrix2d R = Eigen::Vector2d(0.05 * 0.05, 0.01 * 0.01).asDiagonal();
  Eigen::Vector3d truth(0, -10, 0);
  EkfSlam ekf;
  ekf.reset(truth, Eigen::Matrix3d::Identity() * 1e-6);
  std::vector<LandmarkId> id_of(world.size(), kNoLandmark);
  int updates = 0, adds = 0, removes = 0;
  for (int step = 0; step < 300; ++step) {
    const Eigen::Vector2d u(2.0, 0.2 + 0.05 * uni(rng));
    truth = motion.predict(truth, u, 0.25);
    const Eigen::Vector2d u_noisy = u + Eigen::Vector2d(0.05 * gauss(rng), 0.01 * gauss(rng));
    ASSERT_TRUE(ekf.predict(motion.step(ekf.pose(), u_noisy, 0.25)));

    std::vector<Pairing> paired;
    std::vector<std::size_t> fresh;
    std::vector<Eigen::Vector2d> fresh_z;
    for (std::size_t k = 0; k < world.size(); ++k) {
      Eigen::Vector2d z = sensor.predict(truth, world[k]);
      if (z(0) > 20.0) continue;
      z += Eigen::Vector2d(0.05 * gauss(rng), 0.01 * gauss(rng));
      z(1) = wrapAngle(z(1));
      if (id_of[k] == kNoLandmark) {
        fresh.push_back(k);
        fresh_z.push_back(z);
      } else {
        paired.push_back({id_of[k], z, R});
      }
    }
    if (!paired.empty()) {
      ASSERT_TRUE(ekf.update(paired, sensor));
      ++updates;
    }
    for (std::size_t i = 0; i < fresh.size(); ++i) {
      id_of[fresh[i]] = ekf.addLandmark(fresh_z[i], R, sensor);
      ASSERT_NE(id_of[fresh[i]], kNoLandmark);
      ++adds;
    }
    if (step % 17 == 16 && ekf.numLandmarks() > 2) {
      // Forget a random landmark (it will be re-initialised when seen again).
      const std::size_t k = std::uniform_int_distribution<std::size_t>(0, world.size() - 1)(rng);
      if (id_of[k] != kNoLandmark) {
        ASSERT_TRUE(ekf.removeLandmark(id_of[k]));
        id_of[k] = kNoLandmark;
        ++removes;
      }
    }
    if (step % 10 == 0) {
      const Eigen::MatrixXd& P = ekf.covariance();
      ASSERT_EQ((P - P.transpose()).cwiseAbs().maxCoeff(), 0.0) << "step " << step;
      ASSERT_GE(minEigenvalue(P), -1e-9) << "step " << step;
      ASSERT_TRUE(ekf.mean().allFinite());
    }
  }
  expectSymmetricPsd(ekf.covariance());
  EXPECT_GT(updates, 200);
  EXPECT_GT(adds, 20);
  EXPECT_GT(removes, 3);
  // The filter is consistent enough to track the truth.
  EXPECT_LT((ekf.pose().head<2>() - truth.head<2>()).norm(), 1.0);
  for (std::size_t k = 0; k < world.size(); ++k) {
    if (id_of[k] == kNoLandmark) continue;
    EXPECT_LT((ekf.landmark(ekf.indexOf(id_of[k])) - world[k]).norm(), 1.5) << "landmark " << k;
  }
}

}  // namespace test_ekf_slam
}  // namespace ekf_slam
