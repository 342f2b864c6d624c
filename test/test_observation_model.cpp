// Observation models (range-bearing and Cartesian): values, Jacobians (vs central differences),
// inverse, wrap.
#include <cmath>
#include <random>

#include <gtest/gtest.h>

#include <Eigen/Cholesky>
#include <Eigen/Core>

#include "ekf_slam/core/common/angles.h"
#include "ekf_slam/core/filter/observation_model.h"

namespace ekf_slam {
namespace test_observation_model {

constexpr double kStep = 1e-6;
constexpr double kTol = 1e-7;

// Central difference of f (output dim 2) w.r.t. x; `angle_row` (or -1) is wrapped in the
// difference so a bearing crossing +-pi does not produce a 2 pi jump.
template <int N, typename Fun>
Eigen::Matrix<double, 2, N> numericJacobian(Fun f, const Eigen::Matrix<double, N, 1>& x,
                                            int angle_row) {
  Eigen::Matrix<double, 2, N> J;
  for (int k = 0; k < N; ++k) {
    Eigen::Matrix<double, N, 1> xp = x, xm = x;
    xp(k) += kStep;
    xm(k) -= kStep;
    Eigen::Vector2d d = f(xp) - f(xm);
    if (angle_row >= 0) d(angle_row) = wrapAngle(d(angle_row));
    J.col(k) = d / (2.0 * kStep);
  }
  return J;
}

void checkPredictJacobians(const RangeBearingModel& model, const Eigen::Vector3d& xv,
                           const Eigen::Vector2d& m) {
  Matrix23d Hv;
  Eigen::Matrix2d Hm;
  model.predict(xv, m, &Hv, &Hm);
  const Matrix23d Hv_num =
      numericJacobian<3>([&](const Eigen::Vector3d& p) { return model.predict(p, m); }, xv, 1);
  const Eigen::Matrix2d Hm_num =
      numericJacobian<2>([&](const Eigen::Vector2d& q) { return model.predict(xv, q); }, m, 1);
  EXPECT_LT((Hv - Hv_num).norm(), kTol) << "analytic\n" << Hv << "\nnumeric\n" << Hv_num;
  EXPECT_LT((Hm - Hm_num).norm(), kTol) << "analytic\n" << Hm << "\nnumeric\n" << Hm_num;
}

void checkInverseJacobians(const RangeBearingModel& model, const Eigen::Vector3d& xv,
                           const Eigen::Vector2d& z) {
  Matrix23d Gv;
  Eigen::Matrix2d Gz;
  model.inverse(xv, z, &Gv, &Gz);
  const Matrix23d Gv_num =
      numericJacobian<3>([&](const Eigen::Vector3d& p) { return model.inverse(p, z); }, xv, -1);
  const Eigen::Matrix2d Gz_num =
      numericJacobian<2>([&](const Eigen::Vector2d& q) { return model.inverse(xv, q); }, z, -1);
  EXPECT_LT((Gv - Gv_num).norm(), kTol) << "analytic\n" << Gv << "\nnumeric\n" << Gv_num;
  EXPECT_LT((Gz - Gz_num).norm(), kTol) << "analytic\n" << Gz << "\nnumeric\n" << Gz_num;
}

TEST(RangeBearingModel, PredictHandComputedNoOffset) {
  const RangeBearingModel model;
  // Robot at (1, 2) facing +y; landmark 3 ahead and 4 to its right.
  const Eigen::Vector2d z = model.predict(Eigen::Vector3d(1, 2, M_PI / 2), Eigen::Vector2d(5, 5));
  EXPECT_NEAR(z(0), 5.0, 1e-12);
  EXPECT_NEAR(z(1), std::atan2(-4.0, 3.0), 1e-12);
}

TEST(RangeBearingModel, PredictHandComputedWithOffset) {
  // Sensor 2 m ahead of base_link, rotated +90 deg: on a robot at the origin facing +x it sits at
  // (2, 0) looking along +y. A landmark at (2, 3) is straight ahead of it.
  const RangeBearingModel model(Eigen::Vector3d(2, 0, M_PI / 2));
  const Eigen::Vector3d s = model.sensorPose(Eigen::Vector3d::Zero());
  EXPECT_NEAR(s(0), 2.0, 1e-12);
  EXPECT_NEAR(s(1), 0.0, 1e-12);
  EXPECT_NEAR(s(2), M_PI / 2, 1e-12);
  Eigen::Vector2d z = model.predict(Eigen::Vector3d::Zero(), Eigen::Vector2d(2, 3));
  EXPECT_NEAR(z(0), 3.0, 1e-12);
  EXPECT_NEAR(z(1), 0.0, 1e-12);
  // Landmark at (0, 0): 2 m to the sensor's left (it looks along +y).
  z = model.predict(Eigen::Vector3d::Zero(), Eigen::Vector2d(0, 0));
  EXPECT_NEAR(z(0), 2.0, 1e-12);
  EXPECT_NEAR(z(1), M_PI / 2, 1e-12);
}

TEST(RangeBearingModel, BearingWrapsBehindRobot) {
  const RangeBearingModel model;
  const Eigen::Vector3d xv(0, 0, 0);
  // Exactly behind: +pi (the range is (-pi, pi]).
  EXPECT_DOUBLE_EQ(model.predict(xv, Eigen::Vector2d(-10, 0))(1), M_PI);
  // Slightly right of behind: just above -pi; slightly left: just below +pi.
  EXPECT_NEAR(model.predict(xv, Eigen::Vector2d(-10, -0.1))(1), -M_PI + std::atan(0.01), 1e-12);
  EXPECT_NEAR(model.predict(xv, Eigen::Vector2d(-10, 0.1))(1), M_PI - std::atan(0.01), 1e-12);
  // Robot facing -x at yaw = pi: a landmark ahead has bearing 0, not 2 pi.
  EXPECT_NEAR(model.predict(Eigen::Vector3d(0, 0, M_PI), Eigen::Vector2d(-5, 0))(1), 0.0, 1e-12);
  // Robot at yaw -3, landmark in direction +0.3: raw atan2 - yaw = 3.3 must wrap to 3.3 - 2 pi.
  const double b = model.predict(Eigen::Vector3d(0, 0, -3.0),
                                 5.0 * Eigen::Vector2d(std::cos(0.3), std::sin(0.3)))(1);
  EXPECT_NEAR(b, 3.3 - 2 * M_PI, 1e-12);
}

TEST(RangeBearingModel, InnovationWrapsBearing) {
  const Eigen::Vector2d v = RangeBearingModel::innovation(Eigen::Vector2d(10, -M_PI + 0.01),
                                                          Eigen::Vector2d(9, M_PI - 0.01));
  EXPECT_NEAR(v(0), 1.0, 1e-12);
  EXPECT_NEAR(v(1), 0.02, 1e-12);
}

TEST(RangeBearingModel, PredictJacobiansNumeric) {
  const RangeBearingModel plain;
  const RangeBearingModel offset(Eigen::Vector3d(3.78, 0.5, 0.0));
  const RangeBearingModel rotated(Eigen::Vector3d(-0.4, 1.2, -2.5));
  for (const RangeBearingModel* model : {&plain, &offset, &rotated}) {
    checkPredictJacobians(*model, Eigen::Vector3d(1, 2, 0.3), Eigen::Vector2d(10, -4));
    checkPredictJacobians(*model, Eigen::Vector3d(-3, 5, 2.9), Eigen::Vector2d(-20, 7));
    checkPredictJacobians(*model, Eigen::Vector3d(0, 0, -3.1), Eigen::Vector2d(0.5, 30));
    // Landmark right behind the sensor: the bearing is at the wrap point.
    const Eigen::Vector3d xv(2, -1, 0.7);
    const Eigen::Vector3d s = model->sensorPose(xv);
    const Eigen::Vector2d behind =
        s.head<2>() - 8.0 * Eigen::Vector2d(std::cos(s(2)), std::sin(s(2)));
    checkPredictJacobians(*model, xv, behind);
  }
}

TEST(RangeBearingModel, InverseJacobiansNumeric) {
  const RangeBearingModel plain;
  const RangeBearingModel offset(Eigen::Vector3d(3.78, 0.5, 0.0));
  const RangeBearingModel rotated(Eigen::Vector3d(-0.4, 1.2, -2.5));
  for (const RangeBearingModel* model : {&plain, &offset, &rotated}) {
    checkInverseJacobians(*model, Eigen::Vector3d(1, 2, 0.3), Eigen::Vector2d(12, 0.4));
    checkInverseJacobians(*model, Eigen::Vector3d(-3, 5, 2.9), Eigen::Vector2d(40, -1.5));
    checkInverseJacobians(*model, Eigen::Vector3d(0, 0, -3.1), Eigen::Vector2d(3, M_PI));
  }
}

TEST(RangeBearingModel, InverseHandComputed) {
  const RangeBearingModel model(Eigen::Vector3d(1, 0, 0));
  // Robot at (1, 1) facing +y: sensor at (1, 2); beam at -90 deg points along +x.
  const Eigen::Vector2d m =
      model.inverse(Eigen::Vector3d(1, 1, M_PI / 2), Eigen::Vector2d(4, -M_PI / 2));
  EXPECT_NEAR(m(0), 5.0, 1e-12);
  EXPECT_NEAR(m(1), 2.0, 1e-12);
}

TEST(RangeBearingModel, RoundTrips) {
  const RangeBearingModel model(Eigen::Vector3d(3.78, 0.5, 0.2));
  const Eigen::Vector3d poses[] = {{0, 0, 0}, {5, -3, 3.0}, {-10, 2, -2.2}};
  const Eigen::Vector2d obs[] = {{1, 0}, {25, 1.2}, {7, -3.0}, {3, M_PI}};
  for (const auto& xv : poses) {
    for (const auto& z : obs) {
      const Eigen::Vector2d z2 = model.predict(xv, model.inverse(xv, z));
      EXPECT_NEAR(z2(0), z(0), 1e-10);
      EXPECT_NEAR(wrapAngle(z2(1) - z(1)), 0.0, 1e-10);
      EXPECT_GT(z2(1), -M_PI);
      EXPECT_LE(z2(1), M_PI);
    }
    const Eigen::Vector2d m(4, -6);
    EXPECT_LT((model.inverse(xv, model.predict(xv, m)) - m).norm(), 1e-10);
  }
}

// --- Cartesian (x, y) in the sensor frame ------------------------------------------------------

constexpr MeasurementKind kXY = MeasurementKind::kCartesian;

TEST(CartesianModel, PredictHandComputedWithOffset) {
  // Vehicle at (1, 2) facing +y; sensor 0.5 m ahead (world (1, 2.5)), turned 90 deg left (facing
  // -x). A landmark at (-2, 3.5) is 3 m ahead of the sensor and 1 m to its right.
  const RangeBearingModel model(Eigen::Vector3d(0.5, 0.0, M_PI / 2));
  const Eigen::Vector2d z = model.predict(Eigen::Vector3d(1, 2, M_PI / 2), {-2, 3.5}, kXY);
  EXPECT_NEAR(z.x(), 3.0, 1e-12);
  EXPECT_NEAR(z.y(), -1.0, 1e-12);
}

TEST(CartesianModel, JacobiansNumeric) {
  for (const Eigen::Vector3d& offset :
       {Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(3.78, 0.5, 0.3), Eigen::Vector3d(-1, 2, -2.5)}) {
    const RangeBearingModel model(offset);
    for (const Eigen::Vector3d& xv :
         {Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(5, -3, 2.9), Eigen::Vector3d(-7, 1, -1.2)}) {
      const Eigen::Vector2d m(4, 6);
      Matrix23d Hv;
      Eigen::Matrix2d Hm;
      model.predict(xv, m, kXY, &Hv, &Hm);
      const Matrix23d Hv_num = numericJacobian<3>(
          [&](const Eigen::Vector3d& p) { return model.predict(p, m, kXY); }, xv, -1);
      const Eigen::Matrix2d Hm_num = numericJacobian<2>(
          [&](const Eigen::Vector2d& q) { return model.predict(xv, q, kXY); }, m, -1);
      EXPECT_LT((Hv - Hv_num).norm(), kTol) << Hv << "\n" << Hv_num;
      EXPECT_LT((Hm - Hm_num).norm(), kTol) << Hm << "\n" << Hm_num;

      const Eigen::Vector2d z(2.5, -1.5);
      Matrix23d Gv;
      Eigen::Matrix2d Gz;
      const Eigen::Vector2d back = model.inverse(xv, z, kXY, &Gv, &Gz);
      const Matrix23d Gv_num = numericJacobian<3>(
          [&](const Eigen::Vector3d& p) { return model.inverse(p, z, kXY); }, xv, -1);
      const Eigen::Matrix2d Gz_num = numericJacobian<2>(
          [&](const Eigen::Vector2d& q) { return model.inverse(xv, q, kXY); }, z, -1);
      EXPECT_LT((Gv - Gv_num).norm(), kTol) << Gv << "\n" << Gv_num;
      EXPECT_LT((Gz - Gz_num).norm(), kTol) << Gz << "\n" << Gz_num;
      // Round trip and the same point as the range-bearing model sees.
      EXPECT_LT((model.predict(xv, back, kXY) - z).norm(), 1e-12);
      const Eigen::Vector2d rb = model.predict(xv, back);
      EXPECT_LT((RangeBearingModel::sensorPoint(rb, MeasurementKind::kRangeBearing) - z).norm(),
                1e-12);
      EXPECT_NEAR(RangeBearingModel::range(z, kXY), rb(0), 1e-12);
    }
  }
}

TEST(CartesianModel, InnovationIsNotWrapped) {
  const Eigen::Vector2d v = RangeBearingModel::innovation({1.0, 3.0}, {1.0, -3.0}, kXY);
  EXPECT_DOUBLE_EQ(v.y(), 6.0);
  const Eigen::Vector2d w =
      RangeBearingModel::innovation({1.0, 3.0}, {1.0, -3.0}, MeasurementKind::kRangeBearing);
  EXPECT_NEAR(w.y(), 6.0 - 2.0 * M_PI, 1e-12);
}

TEST(CartesianModel, SensorPointJacobianNumeric) {
  const Eigen::Vector2d z(4.0, 0.7);
  Eigen::Matrix2d J;
  RangeBearingModel::sensorPoint(z, MeasurementKind::kRangeBearing, &J);
  const Eigen::Matrix2d J_num = numericJacobian<2>(
      [](const Eigen::Vector2d& q) {
        return RangeBearingModel::sensorPoint(q, MeasurementKind::kRangeBearing);
      },
      z, -1);
  EXPECT_LT((J - J_num).norm(), kTol);
  RangeBearingModel::sensorPoint(z, kXY, &J);
  EXPECT_TRUE(J.isIdentity());
}

// Sample moments of f(x), x ~ N(mu, C), from a fixed-seed stream.
template <int N, typename Fun>
void sampleMoments(Fun f, const Eigen::Matrix<double, N, 1>& mu,
                   const Eigen::Matrix<double, N, N>& C, int angle_row, Eigen::Vector2d* mean,
                   Eigen::Matrix2d* cov) {
  std::mt19937_64 rng(7);
  std::normal_distribution<double> normal;
  const Eigen::Matrix<double, N, N> L = C.llt().matrixL();
  const Eigen::Vector2d f0 = f(mu);
  constexpr int kSamples = 400000;
  Eigen::Vector2d sum = Eigen::Vector2d::Zero();
  Eigen::Matrix2d sum2 = Eigen::Matrix2d::Zero();
  for (int i = 0; i < kSamples; ++i) {
    Eigen::Matrix<double, N, 1> e;
    for (int k = 0; k < N; ++k) e(k) = normal(rng);
    Eigen::Vector2d y = f(mu + L * e) - f0;  // about f(mu): no wrap at +-pi
    if (angle_row >= 0) y(angle_row) = wrapAngle(y(angle_row));
    sum += y;
    sum2 += y * y.transpose();
  }
  *mean = sum / kSamples;
  *cov = sum2 / kSamples - *mean * mean->transpose();
}

// A landmark 200 m away known to 10 m across the line of sight (and 0.3 m along, correlated),
// seen with a 0.1 m range: the second-order terms give the sampled range offset (sigma^2 / 2r =
// 0.25 m) and spread (0.125 m^2, twelve times the noise's 0.01) that the first order misses.
TEST(SecondOrderTerms, RangeBearingMatchSampledMoments) {
  const RangeBearingModel model;
  const Eigen::Vector3d xv(1.0, -2.0, 0.4);
  const Eigen::Vector2d m(150.0, 130.0);
  const Eigen::Vector2d d = m - xv.head<2>();
  const Eigen::Vector2d u = d.normalized(), w(-u(1), u(0));
  Eigen::Matrix2d C = 0.09 * u * u.transpose() + 100.0 * w * w.transpose() +
                      0.6 * (u * w.transpose() + w * u.transpose());
  Eigen::Vector2d mean;
  Eigen::Matrix2d extra;
  RangeBearingModel::rangeBearingSecondOrder(d, C, &mean, &extra);
  Matrix23d Hv;
  Eigen::Matrix2d Hm;
  model.predict(xv, m, &Hv, &Hm);
  const Eigen::Matrix2d first = Hm * C * Hm.transpose();

  Eigen::Vector2d mean_s;
  Eigen::Matrix2d cov_s;
  sampleMoments<2>([&](const Eigen::Vector2d& q) { return model.predict(xv, q); }, m, C, 1, &mean_s,
                   &cov_s);
  EXPECT_NEAR(mean(0), 0.25, 0.01);
  EXPECT_NEAR(mean_s(0), mean(0), 0.03 * mean(0));
  // The bearing's offset (-cov_ab / r^2, 1.5e-5 rad) is below the sample mean's own error.
  EXPECT_NEAR(mean_s(1), mean(1), 4.0 * std::sqrt(cov_s(1, 1) / 400000.0));
  const Eigen::Matrix2d total = first + extra;
  EXPECT_NEAR(cov_s(0, 0), total(0, 0), 0.03 * total(0, 0));
  EXPECT_NEAR(cov_s(1, 1), total(1, 1), 0.03 * total(1, 1));
  EXPECT_NEAR(cov_s(0, 1), total(0, 1), 0.05 * std::abs(total(0, 1)) + 1e-7);
  // The first order alone is far off in range: the reason for the terms.
  EXPECT_LT(first(0, 0), 0.5 * cov_s(0, 0));
}

// relativeCovariance is the first-order covariance of m - s, s the sensor position on the
// vehicle (lever arm): against the Jacobian of m - s w.r.t. (pose, landmark).
TEST(SecondOrderTerms, RelativeCovarianceWithLeverArm) {
  const RangeBearingModel model(Eigen::Vector3d(0.8, -0.3, 0.2));
  const Eigen::Vector3d xv(1.0, 2.0, 0.7);
  Eigen::Matrix<double, 5, 5> A = Eigen::Matrix<double, 5, 5>::Random();
  const Eigen::Matrix<double, 5, 5> P = A * A.transpose();
  const auto rel = [&](const Eigen::Matrix<double, 5, 1>& x) {
    return Eigen::Vector2d(x.tail<2>() - model.sensorPose(x.head<3>()).head<2>());
  };
  Eigen::Matrix<double, 5, 1> x0;
  x0 << xv, 30.0, -4.0;
  const Eigen::Matrix<double, 2, 5> J = numericJacobian<5>(rel, x0, -1);
  const Eigen::Matrix2d expected = J * P * J.transpose();
  const Eigen::Matrix2d C = model.relativeCovariance(xv, P.topLeftCorner<3, 3>(),
                                                     P.block<2, 3>(3, 0), P.block<2, 2>(3, 3));
  EXPECT_LT((C - expected).norm(), 1e-6 * expected.norm());
}

// A return at 250 m with 3 deg of bearing noise: the point's sampled mean lies 0.34 m inwards of
// the first-order point (range sigma^2 / 2) and its spread along the beam is six times the
// range noise; polarSecondOrder gives both.
TEST(SecondOrderTerms, PolarMatchesSampledMoments) {
  const double r = 250.0, dir = 1.1;
  Eigen::Matrix2d C;
  C << 0.01, 0.0005, 0.0005, std::pow(deg2rad(3.0), 2);
  Eigen::Vector2d mean;
  Eigen::Matrix2d extra;
  RangeBearingModel::polarSecondOrder(r, dir, C, &mean, &extra);
  const auto point = [](const Eigen::Vector2d& q) {
    return Eigen::Vector2d(q(0) * std::cos(q(1)), q(0) * std::sin(q(1)));
  };
  Eigen::Matrix2d J;
  J << std::cos(dir), -r * std::sin(dir), std::sin(dir), r * std::cos(dir);
  const Eigen::Matrix2d total = J * C * J.transpose() + extra;
  Eigen::Vector2d mean_s;
  Eigen::Matrix2d cov_s;
  sampleMoments<2>(point, Eigen::Vector2d(r, dir), C, -1, &mean_s, &cov_s);
  const Eigen::Vector2d u(std::cos(dir), std::sin(dir)), w(-u(1), u(0));
  EXPECT_NEAR(u.dot(mean_s), u.dot(mean), 0.03 * std::abs(u.dot(mean)));
  EXPECT_NEAR(u.dot(mean), -0.5 * r * C(1, 1), 1e-12);
  EXPECT_NEAR(w.dot(mean_s), w.dot(mean), 4.0 * std::sqrt(w.dot(cov_s * w) / 400000.0));
  EXPECT_NEAR(u.dot(cov_s * u), u.dot(total * u), 0.05 * u.dot(total * u));
  EXPECT_LT((cov_s - total).norm(), 0.03 * total.norm());
  EXPECT_GT(u.dot(extra * u), 10.0 * C(0, 0));
}

}  // namespace test_observation_model
}  // namespace ekf_slam
